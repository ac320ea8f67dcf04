"""The test suite; its folders mirror the packages: slam_env's layers, agents, the
references and the benchmarks."""
