# Realtime engine (issue 3): strategies, queue, refiner, snapshots, replay.
rost_add_test(test_strategy SOURCES test_strategy.cpp)
rost_add_test(test_engine SOURCES test_engine.cpp test_engine_threads.cpp TIMED)
# The mission session: one policy for deriving and resuming (issue: one mission under every face).
rost_add_test(test_mission SOURCES test_mission.cpp test_mission_records.cpp)
# Replaces operator new and the malloc family with counting versions: its own binary.
rost_add_test(test_nomalloc SOURCES test_nomalloc.cpp TIMED)
# Refinement in windows on every core (issue 13): results independent of the thread count.
rost_add_test(test_parallel SOURCES test_parallel.cpp)
