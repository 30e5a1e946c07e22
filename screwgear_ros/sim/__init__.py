"""One simulation run, with no ROS: the plant (:mod:`.plant`), typed events
(:mod:`.events`) and the one loop, :class:`~.session.Session` and its
:meth:`~.session.Session.advance`; validated commands (:mod:`.commands`) and parameter
sets (:mod:`.parameter_set`, read from files by :mod:`.parameter_file`); the in-process
API (:mod:`.simulation`), scenarios (:mod:`.scenario`), run metrics (:mod:`.metrics`),
the demo law (:mod:`.control`), pacing against the wall clock (:mod:`.pacing`) and the
energy audit (:mod:`.energy`)."""
