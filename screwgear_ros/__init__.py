"""screwgear_ros: a real-time ROS 2 plant of a double screw gear anti-backlash rotary table.

The physics core (params, model, integrator, reference, normalized, plant) imports no
ROS; the node and command-line tools in this package drive it.
"""

__version__ = '0.1.0'
