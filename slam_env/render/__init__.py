"""Pictures: the pygame renderer (the only module that imports pygame), the matplotlib
plots, and the sensor's visible region they draw."""
