# Trust on a long mission (issue 7): the soak and the checkpoint stall.
# Plain programs (their own main), reported in bench/RESULTS.md.
rost_add_bench(bench_soak SOURCES soak.cpp)
rost_add_bench(bench_checkpoint SOURCES checkpoint_stall.cpp)
