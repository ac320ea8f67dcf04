"""Speed and memory: each script measures one cost, as ratios taken side by side in one
run, and prints its table. Run them from the repository root as modules
(``python -m benchmarks.bench_env``)."""
