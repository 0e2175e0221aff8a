"""Values engines default differently, authored in every export so that no engine's default
decides how the object moves (one source of truth for the writers; docs/engines.md).

MuJoCo's constraint softness: its default (solref 0.02 s, critically damped; solimp
0.9-0.95) lets a door sink into its limit and bounce back off it, and lets dry friction
creep. A limit time constant below any step a user runs, which MuJoCo (and Newton's MuJoCo
solver, and Genesis) raise to two time steps, the stiffest its step takes; heavily
overdamped (ratio 20: no rebound velocity left when it lets go) with an impedance near 1
(gravity holds a door a few mrad deep): a limit an inelastic stop and friction stick, as
the hard constraints of Bullet, PhysX and Pinocchio's loop do (measured: ``real2code
simulate``, docs/engines.md). A fixed 2 ms limit was as stiff at 1 ms steps but softer at
shorter ones: a flap falling onto its stop at 0.5 ms steps ended 4.4e-2 rad from the hard
stops, 1.5e-2 with the limit at two steps. Critically damped (ratio 1) gives a door thrown
into its stop back up to a quarter of its speed (a door 0.44 rad off in 2 s).
"""

from __future__ import annotations

LIMIT_SOLREF = (0.0002, 20.0)  # s (two steps of 0.1 ms), damping ratio
# The same impedance at contact as deeper in (dmin = dmax): at the time constant of two steps
# MuJoCo's limit then takes the whole approach velocity in the step it acts, as Bullet's
# does; with 0.99 at contact (0.999 deeper) it left 1 - 0.99 / 0.999 of it, about 1 %, each
# step, so a joint thrown into a limit crept in and left it late: a flap released into its open
# stop ended 0.11 rad from Pinocchio's and 9.3e-2 from Bullet's, which agree to 2e-4 until
# its second arrival; now 2.0e-2 and 3.8e-5 (bench/limit_steps.py, docs/engines.md).
LIMIT_SOLIMP = (0.999, 0.999, 0.001, 0.5, 2.0)
FRICTION_SOLREF = (0.002, 1.0)

# MuJoCo's limit acts only once a joint is past it (distance < margin, margin 0 by default),
# the hard stops of PhysX, Pinocchio, SAPIEN and Bullet as soon as it is at it. A joint
# observed at its limit (a reconstruction's range often ends at the observed state) and
# pushed into it would move one step (v * dt) into MuJoCo's and not into theirs: a heavy
# flap then falls from a few mrad further and ~1 ms later, 1.7e-2 rad apart after its fall
# (`real2code simulate`, docs/engines.md). A margin far below anything measured makes the
# limit act at contact; MuJoCo's margin amounts to the range narrowed by it (rad or m).
LIMIT_MARGIN = 1e-6

# PhysX damps every rigid body it is not told otherwise about (linear and angular 0.05).
LINK_DAMPING = 0.0

# PhysX's scene solver: its default TGS integrates a freely swinging door less exactly.
PHYSX_SOLVER = "PGS"

# MuJoCo's several contact points per pair of convex pieces (its default): Newton's MuJoCo
# solver turns them off unless the file says otherwise, and with one point per pair a 5 cm
# box on a drawer's floor rests 5.4 mm deep where MuJoCo's four hold it at 0.1 mm (plain
# MuJoCo with the flag off does the same: `real2code simulate --experiments drop`).
MULTICCD = True
