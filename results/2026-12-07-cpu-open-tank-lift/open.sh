#!/bin/bash
# The buoyancy test's run (tests/tests/validation/buoyancy.rs) with the tank left open and
# filled to 0.3 m, from the repository root: open.sh OUT [--set ...]. The closed run:
# open.sh OUT --set domain.closed_top=true --set 'fluid.blocks.0.max=[0.2, 0.4, 0.2]'
out=$1; shift
target/release/couplet run scenes/hydrostatic-tank.toml --out $out \
 --set fluid.spacing=0.02 --set fluid.support=2.0 --set fluid.sound_speed=17.5 \
 --set effects.artificial_viscosity=0.2 --set fluid.kinematic_viscosity=0.0 --set time.end=0.3 \
 --set effects.gradient_correction=true --set effects.particle_shifting=0.1 \
 --set 'bodies=[{ name = "ball", shape = { sphere = { radius = 0.05 } }, density = 1250.0, position = [0.1, 0.2, 0.1], motion = "fixed", coupling = "resolved" }]' "$@"
