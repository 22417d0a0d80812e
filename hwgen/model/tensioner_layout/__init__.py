"""Layout of the worm-gear tensioner at the tip (numpy only, no CAD kernel).

Robot frame as everywhere: the backbone along +y, the tip disk's outer face at
y = y_face, x across the strip, z through it. The tensioner sits on that face.

One *unit* per channel: a wheel part (gear + spool drum) turning on two dowel stubs along
z, and a worm along x meshing on the wheel's +y side (-y in the left column). The worm sits
between the spine and a far post: it turns on a dowel pressed through the post at its far
end, and at its near end on a drive shaft that goes through a small hole in the spine into
the worm's hex bore; the shaft's flange outside the spine carries the socket for the hex
key. The worm's end faces bear on the spine and the post (its thrust).

Every tendon runs in its own plane z = z_e (its tip eyelet's z) in one straight line from
the tip eyelet to a tangent point of its channel's drum, where it winds in its own groove (two
of one channel that leave the tip closer than a groove and its flanges share one, wide enough
for both); the drum's winding zones sit at those z, the gear at one end of the drum, the housing's
shelves above and below. Units stand in a right column (+x) and a left one (a right unit
turned 180° about z); both share one wheel-axis |x| (x_u) and a spine wall on their outer
side that carries the worms. Units are stacked along +y; those whose parts would reach the
strip's clamp go beyond it.

The layout is a search over arrangements: the whole tensioner as designed or turned over
(180° about y), the order of the units along y and the column each stands in, and which end
of its drum each gear takes. For each arrangement x_u is the smallest value at which every
tendon clears every other part by ``tensioner.tendon_clearance`` beyond its own diameter,
and the stack is lifted off the tip until no tendon turns by more than
``tensioner.max_exit_deg`` at its tip eyelet. The lightest arrangement that fits wins (the
housing's material estimated from its members); the candidates are generated from the
geometry alone, so listing the channels in another order or turning the robot over gives
the same verdict. The exported meshes are measured again by the checks.

A channel with two tendons winds them in the same sense by default (``tensioner.winding``):
turning the worm then shortens both equally, which is how the paper pre-tensions the
actuating pair so the beam stays straight (Sect. III-A, IV). Wound in opposite senses the
worm hauls one in as it pays the other out, and bends the robot.

The housing is described here as data (boxes and cylinders to fuse, and to cut), so the
search can weigh it and the CAD stage only turns it into a solid. Fasteners follow the
process: resin (SLA) is brittle and cracks around a melted-in insert, so it takes hex nuts
in traps; FDM thermoplastics take heat-set inserts.

The steps, each in its module: sizes (fixed part sizes, fasteners, what the parameters make of
them) → result (the layout's data types) → arrangement (tip eyelets, one unit along z, the strip
clamp, the candidates) → placement (x_u and the lift for one candidate, tendon clearance) →
housing (its members and cuts) → search (the ranking, branch and bound, the refusal).
"""
from .result import Member, TendonRun, TensionerLayout, Unit
from .search import layout
from .sizes import Fastening, NoFit, fastening, joint, spool_wall_problem, tip_joint

__all__ = ["Fastening", "Member", "NoFit", "TendonRun", "TensionerLayout", "Unit", "fastening", "joint", "layout",
           "spool_wall_problem", "tip_joint"]
