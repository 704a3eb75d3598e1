# Realtime engine (issue 3): strategies, queue, refiner, snapshots, replay.
rost_add_test(test_strategy SOURCES test_strategy.cpp)
rost_add_test(test_engine SOURCES test_engine.cpp)
