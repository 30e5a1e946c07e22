"""The 3-DOF model of ``shared/spec/model.md``, as compiled kernels and plain functions,
with no ROS: the packed parameter layout (:mod:`.packed`), the mesh law (:mod:`.mesh`),
the drive torques per mode (:mod:`.drive`), the equations of motion (:mod:`.motion`), the
preload equilibrium (:mod:`.equilibrium`), bearing friction (:mod:`.friction`), what the
encoders measure (:mod:`.sensors`), the paper's derived quantities (:mod:`.quantities`)
and how every kernel is compiled (:mod:`.jit`)."""
