"""The model-file reader by concern: :mod:`.locator` (line numbers by field path),
:mod:`.expressions` (the safe parse of expression strings and its checks), :mod:`.reader` (the
schema read into a Model), :mod:`.model_file` (the result, which locates later errors).
:mod:`gpmegen.model.toml_file` is its public face."""
