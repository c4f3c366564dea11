"""The reference study (statics, simulation), results files and figures."""
