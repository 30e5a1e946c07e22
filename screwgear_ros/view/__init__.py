"""What a viewer sees of the table: its URDF (:mod:`.urdf`) and its ``table_markers``
(:mod:`.markers`), drawn from the layout of :mod:`screwgear_ros.view.layout`.

Nothing here imports rclpy: the markers are written as CDR bytes by
:mod:`screwgear_ros.bag.cdr`, the URDF is plain text.
"""
