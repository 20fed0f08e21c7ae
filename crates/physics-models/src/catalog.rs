//! What the library holds: every built-in model by the name it loads under, with one line on
//! what it is, its licence and where it comes from. `list_models` shows these beside what the
//! server reads off each model (joints, degrees of freedom, mass, base); NOTICE (at the
//! repository's root) has every licence's text. The build script checks that each model's file
//! is there.
//!
//! Names: pybullet_data's own for its models (`kuka_iiwa/model.urdf`, `r2d2.urdf`), so
//! PyBullet prompts work unchanged; `mujoco/<file>.xml` for Gymnasium's MuJoCo models;
//! `menagerie/<model dir>/<file>.xml` for MuJoCo Menagerie's (none yet). A model's meshes sit
//! beside it under the paths its file names.

/// One built-in model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Model {
    /// The name `load_urdf` / `load_mjcf` take (`file_path`); `.urdf` or `.xml`.
    pub name: &'static str,
    /// One line on what it is and how it is usually loaded.
    pub description: &'static str,
    /// Its licence (SPDX identifier where there is one).
    pub license: &'static str,
    /// Where it comes from (NOTICE has the details).
    pub source: &'static str,
}

const PYBULLET: &str = "pybullet_data (PyPI pybullet 3.2.7)";
const GYMNASIUM: &str = "Gymnasium 1.4.0 (gymnasium/envs/mujoco/assets), unchanged";

/// Every built-in model in the library, robots first.
pub const MODELS: &[Model] = &[
    Model {
        name: "kuka_iiwa/model.urdf",
        description: "KUKA LBR iiwa 14, 7-joint arm (base mass 0: it stands fixed)",
        license: "BSD-2-Clause (AASS Research Center, Orebro University)",
        source: PYBULLET,
    },
    Model {
        name: "franka_panda/panda.urdf",
        description: "Franka Emika Panda, 7-joint arm with a 2-finger gripper; load with use_fixed_base: true",
        license: "Apache-2.0 (Franka Emika)",
        source: PYBULLET,
    },
    Model {
        name: "r2d2.urdf",
        description: "R2-D2 toy robot: 4 wheels, head swivel, gripper (ROS urdf_tutorial)",
        license: "BSD-3-Clause (ROS urdf_tutorial)",
        source: PYBULLET,
    },
    Model {
        name: "racecar/racecar.urdf",
        description: "MIT RACECAR 1:10 car: 4 wheels, 2 steering hinges",
        license: "Zlib (bullet3 data; see NOTICE)",
        source: PYBULLET,
    },
    Model {
        name: "husky/husky.urdf",
        description: "Clearpath Husky 4-wheel ground vehicle",
        license: "BSD-3-Clause (Clearpath Robotics)",
        source: PYBULLET,
    },
    Model {
        name: "a1/a1.urdf",
        description: "Unitree A1 quadruped, 12 joints; without motors its legs fold",
        license: "BSD-3-Clause (Unitree Robotics)",
        source: PYBULLET,
    },
    Model {
        name: "cartpole.urdf",
        description: "Cart on a 30 m rail (prismatic) with a free pole (continuous); the rail is fixed",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "table/table.urdf",
        description: "Static table, 1.5 x 1 m top at z = 0.625 m",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "table_square/table_square.urdf",
        description: "Static square table, 0.6 x 0.6 m top at z = 0.64 m",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "tray/traybox.urdf",
        description: "Static tray, 0.6 x 0.6 m floor with sloped walls",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "lego/lego.urdf",
        description: "Lego brick, 32 x 32 x 23 mm, 0.1 kg",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "domino/domino.urdf",
        description: "Domino tile, 25 g",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "jenga/jenga.urdf",
        description: "Jenga block, 50 g",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "cube_small.urdf",
        description: "5 cm cube, 0.1 kg",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "sphere_small.urdf",
        description: "Ball, radius 3 cm, 0.1 kg",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "sphere2.urdf",
        description: "Ball, radius 0.5 m, 10 kg",
        license: "Zlib (bullet3)",
        source: PYBULLET,
    },
    Model {
        name: "mujoco/ant.xml",
        description: "Gymnasium Ant: 4-legged walker, 8 hinges, free base, with its floor",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/half_cheetah.xml",
        description: "Gymnasium HalfCheetah: planar runner, 6 leg hinges on a planar root",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/hopper.xml",
        description: "Gymnasium Hopper: planar one-legged hopper, 3 leg hinges on a planar root",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/humanoid.xml",
        description: "Gymnasium Humanoid: 17 hinges, free base, standing",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/humanoidstandup.xml",
        description: "Gymnasium HumanoidStandup: the humanoid lying on its floor",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/inverted_double_pendulum.xml",
        description: "Gymnasium InvertedDoublePendulum: cart on a rail with two hinged poles",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/inverted_pendulum.xml",
        description: "Gymnasium InvertedPendulum: cart on a rail with one hinged pole",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/pusher.xml",
        description: "Gymnasium Pusher: 7-joint arm, an object and a goal on a table (gravity 0: use_model_options)",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/reacher.xml",
        description: "Gymnasium Reacher: 2-link planar arm and a target on an arena",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/swimmer.xml",
        description: "Gymnasium Swimmer: 3-link planar swimmer (its fluid is not simulated)",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
    Model {
        name: "mujoco/walker2d.xml",
        description: "Gymnasium Walker2d: planar biped, 6 leg hinges on a planar root",
        license: "MIT (Farama Foundation, OpenAI)",
        source: GYMNASIUM,
    },
];

/// Library folders whose models live elsewhere in the repository (relative to this crate),
/// read from there by the build script: Gymnasium's models are the MJCF test fixtures, the
/// files MuJoCo's reference was computed from.
pub const ELSEWHERE: &[(&str, &str)] = &[("mujoco/", "../../tests/fixtures/mjcf/")];
