# ROS 1 (src/ros): rost_node on a private ROS master, and bags in the rost
# tool. Each script runs under /usr/bin/python3 (Debian's, with rospy and
# rosbag) after sourcing build/ros/setup.sh under `set -u` (it must be safe
# there). They need the real footage (the vision_fetch_footage fixture) and
# skip without it outside CI.
if(NOT ROST_HAVE_ROS)
  return()
endif()
foreach(_t IN ITEMS node bag)
  add_test(NAME ros_${_t}
           COMMAND env -u PYTHONPATH -u ROS_PACKAGE_PATH sh -c "set -u; . '${PROJECT_BINARY_DIR}/ros/setup.sh' && exec /usr/bin/python3 '${CMAKE_CURRENT_SOURCE_DIR}/ros/test_${_t}.py' '${PROJECT_BINARY_DIR}' '${PROJECT_SOURCE_DIR}/data'")
  set_tests_properties(ros_${_t} PROPERTIES FIXTURES_REQUIRED rost_footage TIMEOUT 300 SKIP_RETURN_CODE 77)
endforeach()
