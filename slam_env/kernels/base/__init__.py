"""The kernels' foundation: how they are compiled (and cached), angle wrapping, small
dense linear algebra, random variates from uniforms, and the seeds' motion and
measurement models as scalar compiled functions."""
