"""agnav fusion: the thesis' navigation sensor module estimators and the GNSS/INS filter."""
