# rost_msgs without catkin: C++ headers (gencpp) and Python modules (genpy)
# from ros/rost_msgs, the package as ROS tools look it up, and
# build/ros/setup.sh. Included from src/ros/CMakeLists.txt.
set(_msgs_src ${PROJECT_SOURCE_DIR}/ros/rost_msgs)
set(_ros_out ${PROJECT_BINARY_DIR}/ros)
set(_msg_files ${_msgs_src}/msg/FrameTopics.msg ${_msgs_src}/msg/TopicModel.msg ${_msgs_src}/msg/VehicleLifting.msg
               ${_msgs_src}/msg/TopicLifting.msg)
set(_srv_files ${_msgs_src}/srv/GetTopicModel.srv ${_msgs_src}/srv/SetTopicModel.srv)
set(_gen_include -I rost_msgs:${_msgs_src}/msg -I std_msgs:${ROST_STD_MSGS_MSG})
set(_cpp_out ${_ros_out}/include/rost_msgs)
set(_py_out ${_ros_out}/python/rost_msgs)
set(_cpp_headers "")
set(_py_files ${_py_out}/__init__.py ${_py_out}/msg/__init__.py ${_py_out}/srv/__init__.py)
set(_cpp_commands "")
foreach(_f IN LISTS _msg_files _srv_files)
  get_filename_component(_n ${_f} NAME_WE)
  list(APPEND _cpp_headers ${_cpp_out}/${_n}.h)
  list(APPEND _cpp_commands COMMAND ${ROST_ROS_PYTHON} ${ROST_GENCPP} ${_f} -p rost_msgs -o ${_cpp_out}
                            -e /usr/share/gencpp ${_gen_include})
endforeach()
foreach(_f IN LISTS _srv_files)
  get_filename_component(_n ${_f} NAME_WE)
  list(APPEND _cpp_headers ${_cpp_out}/${_n}Request.h ${_cpp_out}/${_n}Response.h)
  list(APPEND _py_files ${_py_out}/srv/_${_n}.py)
endforeach()
foreach(_f IN LISTS _msg_files)
  get_filename_component(_n ${_f} NAME_WE)
  list(APPEND _py_files ${_py_out}/msg/_${_n}.py)
endforeach()
add_custom_command(OUTPUT ${_cpp_headers} ${_py_files}
  ${_cpp_commands}
  COMMAND ${ROST_ROS_PYTHON} ${ROST_GENPY_MSG} -p rost_msgs -o ${_py_out}/msg ${_gen_include} ${_msg_files}
  COMMAND ${ROST_ROS_PYTHON} ${ROST_GENPY_MSG} --initpy -p rost_msgs -o ${_py_out}/msg
  COMMAND ${ROST_ROS_PYTHON} ${ROST_GENPY_SRV} -p rost_msgs -o ${_py_out}/srv ${_gen_include} ${_srv_files}
  COMMAND ${ROST_ROS_PYTHON} ${ROST_GENPY_SRV} --initpy -p rost_msgs -o ${_py_out}/srv
  COMMAND ${CMAKE_COMMAND} -E touch ${_py_out}/__init__.py
  DEPENDS ${_msg_files} ${_srv_files} ${ROST_GENCPP} ${ROST_GENPY_MSG} ${ROST_GENPY_SRV}
  COMMENT "Generating rost_msgs (gencpp, genpy)"
  VERBATIM)
add_custom_target(rost_msgs_generate ALL DEPENDS ${_cpp_headers} ${_py_files})
add_library(rost_msgs INTERFACE)
add_dependencies(rost_msgs rost_msgs_generate)
target_include_directories(rost_msgs SYSTEM INTERFACE ${_ros_out}/include ${ROST_ROS_INCLUDE_DIRS})

# The package as rospack, rosbag and rostopic look it up (ROS_PACKAGE_PATH),
# and the environment: `. build/ros/setup.sh`.
foreach(_f ${_msgs_src}/package.xml ${_msg_files} ${_srv_files})
  file(RELATIVE_PATH _rel ${_msgs_src} ${_f})
  configure_file(${_f} ${_ros_out}/share/rost_msgs/${_rel} COPYONLY)
endforeach()
configure_file(${CMAKE_CURRENT_SOURCE_DIR}/setup.sh.in ${_ros_out}/setup.sh @ONLY)

