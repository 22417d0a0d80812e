"""`hwgen sim`: the robot as printed, as a MuJoCo model, checked against hwgen's own statics.

A stage after the checks: it reads a build (the manifest's parts and masses, the check report's
measured eyelets and weights) and the model (the statics' sections, spans, tendon springs and
states), and writes OUT/<design>/sim/.

    reference.py   the statics it is checked against, through one function (statics_reference)
    parts.py       the printed parts read from the build: masses, centres, inertias, eyelets, runs
    chain.py       the strip's hinges, sprung as the statics springs it
    mjcf.py        robot.xml: bodies, sites, tendons, drums, keyframes
    measure.py     the loaded model measured: equilibria, tip stiffness, dynamics
    plot.py        sim.png
    run.py         all of it into sim/ (sim.json)
"""
