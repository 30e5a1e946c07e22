"""Integrating the model: RK4 (:mod:`.rk`, the one step; :mod:`.integrator`, the node's hot
loop with contact and friction changes located), RK4's stability limit
(:mod:`.stability`), the DOP853 reference solution check_run compares with
(:mod:`.dop853`, :mod:`.reference`), and where the compiled kernels are
(:mod:`.kernels`)."""
