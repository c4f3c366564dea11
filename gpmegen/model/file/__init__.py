"""The model-file reader by concern: :mod:`.locator` (line numbers by field path),
:mod:`.expressions` (the safe parse of expression strings and its checks), :mod:`.schema` (the keys
each table takes), :mod:`.reader` (the file read into a Model, through the mixins :mod:`.values`
(single values), :mod:`.chain_reading` (the chain), :mod:`.element_reading` (signals, drives,
and the element kinds' entries, each read by its kind in :mod:`gpmegen.model.elements`) and
:mod:`.constraint_reading` (constraints, dependent coordinates, actuators, initial values)),
:mod:`.urdf_section` (a chain from a URDF), :mod:`.model_file` (the result, which locates later
errors). :mod:`gpmegen.model.toml_file` is its public face."""
