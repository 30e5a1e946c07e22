"""The parameters: one declaration per parameter, history included (:mod:`.declarations`),
the validated sets (:mod:`.table`: :class:`~.table.TableParams`,
:class:`~.table.SimSettings`), the shipped configuration files (:mod:`.config_files`), the
line-aware YAML reader of hand-written files (:mod:`.yaml_reader`) and the documents
generated from the declarations (:mod:`.docs`).
"""
