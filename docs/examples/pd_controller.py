"""A controller for a scenario file (``use: pd_controller:make``): run_scenario calls
``make(setpoint, **parameters)`` once per run and ``controller(observation)`` every tick."""


def make(setpoint, kp=3000.0, kd=200.0, limit=300.0):
    def controller(o):
        wanted = kp * (setpoint(o.time) - o.position[1]) - kd * o.velocity[1]
        return max(-limit, min(limit, wanted))
    return controller
