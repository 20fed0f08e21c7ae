#!/usr/bin/env bash
# No regression where no multibody moves: instructions of the same work built against the
# vendored rapier3d (crates/rapier3d, PATCHES.md) and against the rapier3d 0.36.1 release.
# The work is `crates/physics-core/examples/step_cost.rs` on one thread: the 1000-box pile built
# and settled, snapshotted, restored, stepped 300 times, a box stepped 20,000 times in one
# command and 2,000 in one-step commands. Dev-only (valgrind); writes nothing in this checkout.
#
#   scripts/upstream_regression.sh            # prints Ir of the program and of World::step_here
#
# The release copy is this commit's tree in a temporary directory with `[patch.crates-io]`
# removed; physics-core names the patched API in four places (the engine rule's
# `multibody_dynamics`, the tree path's augmented mass read and patch 8's quiet force door),
# which are stubbed there: the example never builds a multibody and applies no force, so they
# are never reached.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
target=${CARGO_TARGET_DIR:-$root/target}

git -C "$root" archive HEAD | tar -x -C "$tmp"
python3 - "$tmp" <<'PY'
import pathlib, re, sys
t = pathlib.Path(sys.argv[1])
def edit(rel, old, new, count=1):
    p = t / rel
    s = p.read_text()
    if s.count(old) < count:
        raise SystemExit(f"{rel}: expected text not found: {old!r}")
    p.write_text(s.replace(old, new))
edit("Cargo.toml", '[patch.crates-io]\nrapier3d = { path = "crates/rapier3d" }\n', "")
p = t / "crates/physics-core/src/world/mod.rs"
s, n = re.subn(r"(self\.)?physics\.integration_parameters\.multibody_dynamics = [a-z_.]*multibody_dynamics\(\);", "", p.read_text())
assert n == 3, n
p.write_text(s)
p = t / "crates/physics-core/src/engine.rs"
s, n = re.subn(r"    /// How the engine computes multibodies[^\n]*\n    pub fn multibody_dynamics\(self\)[\s\S]*?\n    }\n", "", p.read_text())
assert n == 1, n
p.write_text(s)
edit("crates/physics-core/src/world/robot.rs", "let m = mb.augmented_mass();\n            return (m.nrows() == n && m.ncols() == n).then(|| m * x);", "return None;")
# Patch 8's quiet door (rule 4): the release has no `one_step_forces`; every write goes through
# `get_mut`, through a local stand-in for `OneStepForces` (the example applies no forces).
edit("crates/physics-core/src/world/step_forces.rs", "use rapier3d::dynamics::{OneStepForces, RigidBodyHandle};", """use rapier3d::dynamics::{RigidBody, RigidBodyHandle};
use rapier3d::math::{AngVector, Vector};
pub(super) struct OneStepForces<'a>(&'a mut RigidBody);
impl<'a> OneStepForces<'a> {
    fn on(b: &'a mut RigidBody) -> Self { Self(b) }
    pub(super) fn add_force(&mut self, f: Vector) { self.0.add_force(f, true) }
    pub(super) fn add_force_at_point(&mut self, f: Vector, p: Vector) { self.0.add_force_at_point(f, p, true) }
    pub(super) fn add_torque(&mut self, t: AngVector) { self.0.add_torque(t, true) }
    pub(super) fn reset_forces(&mut self) { self.0.reset_forces(false) }
    pub(super) fn reset_torques(&mut self) { self.0.reset_torques(false) }
}""")
edit("crates/physics-core/src/world/step_forces.rs", "if let Some(mut quiet) = bodies.one_step_forces(body) {", "if let Some(mut quiet) = None::<OneStepForces> {")
PY

build() { (cd "$1" && CARGO_TARGET_DIR="$target" cargo build --release -q -p physics-core --example step_cost) && cp "$target/release/examples/step_cost" "$tmp/step_cost_$2"; }
build "$tmp" release
build "$root" vendored
for v in release vendored; do
  valgrind --tool=callgrind --callgrind-out-file="$tmp/$v.out" "$tmp/step_cost_$v" 1 >/dev/null 2>&1
  total=$(callgrind_annotate "$tmp/$v.out" | awk '/PROGRAM TOTALS/ {print $1}')
  step=$(callgrind_annotate --inclusive=yes "$tmp/$v.out" | awk '/World::step_here/ {print $1; exit}')
  echo "REPORT upstream_regression $v: program $total Ir, World::step_here $step Ir"
done
