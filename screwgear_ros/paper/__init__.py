"""The paper report: one module per section, each ``compute(quick)`` → ``render(result, outdir)``.

:func:`screwgear_ros.paper.builder.build` runs them all and writes ``report.md`` with its
PNG figures. Needs no ROS.
"""
