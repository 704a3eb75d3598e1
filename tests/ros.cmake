# ROS 1 (src/ros): rost_node on a private ROS master, and bags in the rost
# tool. Each script runs under /usr/bin/python3 (Debian's, with rospy and
# rosbag) after sourcing build/ros/setup.sh under `set -u` (it must be safe
# there). ros_node and ros_bag need the real footage (the
# vision_fetch_footage fixture) and skip without it outside CI; ros_launch
# (rost.launch through roslaunch) and ros_transport (~image_transport) play
# synthetic images and always run; so does ros_fleet (two rost_nodes on two
# bags and rost_merge_node under one master).
if(NOT ROST_HAVE_ROS)
  return()
endif()
function(rost_add_ros_test name)
  add_test(NAME ros_${name}
           COMMAND env -u PYTHONPATH -u ROS_PACKAGE_PATH sh -c "set -u; . '${PROJECT_BINARY_DIR}/ros/setup.sh' && exec /usr/bin/python3 '${CMAKE_CURRENT_SOURCE_DIR}/ros/test_${name}.py' '${PROJECT_BINARY_DIR}' '${PROJECT_SOURCE_DIR}/data'")
endfunction()
foreach(_t IN ITEMS node bag)
  rost_add_ros_test(${_t})
  set_tests_properties(ros_${_t} PROPERTIES FIXTURES_REQUIRED rost_footage TIMEOUT 300 SKIP_RETURN_CODE 77)
endforeach()
foreach(_t IN ITEMS launch transport fleet)
  rost_add_ros_test(${_t})
  set_tests_properties(ros_${_t} PROPERTIES TIMEOUT 180)
endforeach()

# The bridge's library side (no ROS master): frames and topic models named by
# slot, the lifting read through them.
rost_add_test(test_ros_bridge SOURCES test_ros_bridge.cpp LIBS rost_ros_bridge rost::vision)
