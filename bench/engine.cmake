# Realtime engine (issue 3): ingest latency, time-budget accuracy, streaming cost.
rost_add_bench(bench_engine SOURCES bench_engine.cpp)
