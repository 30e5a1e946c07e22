"""The table in-process, with no ROS: :class:`~.simulation.Simulation` (step it, or close a
loop with ``run(controller)``, optionally recording the run as table_sim records it), its
samples (:mod:`.samples`), scenario files (:mod:`.scenario`), setpoint profiles and the
metrics of a run (:mod:`.metrics`). It sits above the recording (:mod:`screwgear_ros.runs`)
so that a run can be recorded, and below the tools that drive it (design, sweeps,
identification, the Gymnasium environment)."""
