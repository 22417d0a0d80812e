"""What the robot is, as plain numpy data: no CAD kernel, no files.

routing (where each tendon passes each disk) → kinematics (eq. (1)–(2)) → gearing (worm and
wheel) → crossings (where tendons meet the strip) → specs (frozen part specifications) →
tensioner_layout (where the worm drives go) → plan (every part's spec, the design report) →
feasibility (parameters that pass the schema but describe no buildable robot).
"""
