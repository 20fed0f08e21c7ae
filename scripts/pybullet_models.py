"""Copies the pybullet_data models physics-mcp ships as built-ins into
crates/physics-models/models/ (the library's committed source files), keeping each file's
pybullet_data name, and only what the server reads: the URDF and the meshes its <collision>
elements name. Visual-only meshes, textures and materials are dropped (the viewer and camera
draw collision shapes); the URDFs are unchanged, so their <visual> elements still name the
dropped files. Franka's LICENSE.txt (Apache-2.0) is kept beside its model. NOTICE lists every
model with its source and licence.

Dev-only (pybullet is not a dependency):
  pip download pybullet==3.2.7 --no-deps -d /tmp/pb && unzip -q /tmp/pb/pybullet-*.whl 'pybullet_data/*' -d /tmp/pb
  python3 scripts/pybullet_models.py /tmp/pb/pybullet_data
"""
import os
import shutil
import sys
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "crates", "physics-models", "models")
# The built-in URDFs, by their pybullet_data names (crates/physics-models/src/catalog.rs).
URDFS = ["kuka_iiwa/model.urdf", "franka_panda/panda.urdf", "r2d2.urdf", "racecar/racecar.urdf",
         "husky/husky.urdf", "a1/a1.urdf", "cartpole.urdf", "table/table.urdf",
         "table_square/table_square.urdf", "tray/traybox.urdf", "lego/lego.urdf",
         "domino/domino.urdf", "jenga/jenga.urdf", "cube_small.urdf", "sphere_small.urdf",
         "sphere2.urdf"]


def collision_meshes(path):
    """The mesh files a URDF's <collision> elements name, resolved as physics-mcp resolves
    them (relative to the URDF's folder; package://pkg/rest as rest without its first part,
    or whole, in that folder)."""
    folder = os.path.dirname(path)
    out = []
    for link in ET.parse(path).getroot().iter("link"):
        for col in link.findall("collision"):
            for mesh in col.iter("mesh"):
                name = mesh.get("filename")
                if name.startswith("package://"):
                    rest = name[len("package://"):]
                    tries = [rest.split("/", 1)[1] if "/" in rest else rest, rest]
                else:
                    tries = [name]
                found = [t for t in tries if os.path.isfile(os.path.join(folder, t))]
                if not found:
                    sys.exit(f"{path}: collision mesh {name} not found")
                out.append(os.path.normpath(os.path.join(folder, found[0])))
    return sorted(set(out))


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    data = os.path.abspath(sys.argv[1])
    total = 0
    # Files kept beside the models: a licence text the model's licence asks to pass on.
    extra = [os.path.join(data, "franka_panda", "LICENSE.txt")]
    for urdf in URDFS + [None]:
        if urdf is None:
            files = extra
        else:
            src = os.path.join(data, urdf)
            files = [src] + collision_meshes(src)
        for f in files:
            rel = os.path.relpath(f, data)
            dst = os.path.join(OUT, rel)
            os.makedirs(os.path.dirname(dst), exist_ok=True)
            shutil.copyfile(f, dst)
            total += os.path.getsize(f)
            print(f"{rel} ({os.path.getsize(f)} bytes)")
    print(f"copied {total} bytes into {os.path.normpath(OUT)}")


main()
