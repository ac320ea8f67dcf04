"""The plain implementations the tests and benchmarks hold the compiled code to: the
dense textbook EKF-SLAM, the ideal EKF, the batch least-squares smoother, the numpy
belief code the kernels replaced, Chipmunk's tree as Python objects, a plain Dijkstra."""
