# Shared body of the interface packages' CMakeLists.txt: each package declares its project and includes this.
# The <depend>s are read from package.xml; interface files are globbed.
file(READ "${CMAKE_CURRENT_SOURCE_DIR}/package.xml" _pkg_xml)
string(REGEX MATCHALL "<depend>[^<]+</depend>" _deps "${_pkg_xml}")
list(TRANSFORM _deps REPLACE "</?depend>" "")

# The ros-jazzy-* wheels install a ROS prefix (share/, lib/, include/) into
# the Python prefix they were installed to: the venv, or pip's build-isolation
# overlay. Find every such prefix on sys.path; give it to CMake and ament.
find_package(Python3 REQUIRED COMPONENTS Interpreter)
execute_process(
  COMMAND "${Python3_EXECUTABLE}" -c
    "import os, sys; seen=[]; [seen.append(q) for p in sys.path for q in [os.path.realpath(os.path.join(p, '..', '..', '..'))] if os.path.isdir(os.path.join(q, 'share', 'ament_index')) and q not in seen]; print('|'.join(seen)); print(os.path.realpath(sys.prefix))"
  OUTPUT_VARIABLE _out OUTPUT_STRIP_TRAILING_WHITESPACE
  COMMAND_ERROR_IS_FATAL ANY)
string(REPLACE "\n" ";" _out "${_out}")
list(GET _out 0 ROS_WHEEL_PREFIXES)
string(REPLACE "|" ";" ROS_WHEEL_PREFIXES "${ROS_WHEEL_PREFIXES}")
list(GET _out -1 _py_prefix)
# In pip's build isolation the invoking venv is not on sys.path, but CMake
# would still find packages in it through PATH (<venv>/bin): keep it out.
if(NOT _py_prefix IN_LIST ROS_WHEEL_PREFIXES)
  list(APPEND CMAKE_IGNORE_PREFIX_PATH "${_py_prefix}")
endif()
if(NOT ROS_WHEEL_PREFIXES)
  message(FATAL_ERROR "no ROS wheel prefix found on sys.path of ${Python3_EXECUTABLE}")
endif()
# A package may add prefixes it built itself (ROS_EXTRA_PREFIXES): nav2_msgs its geographic_msgs.
list(APPEND ROS_WHEEL_PREFIXES ${ROS_EXTRA_PREFIXES})
message(STATUS "ROS wheel prefixes: ${ROS_WHEEL_PREFIXES}")
list(PREPEND CMAKE_PREFIX_PATH ${ROS_WHEEL_PREFIXES})
string(REPLACE ";" ":" _ament_prefix_path "${ROS_WHEEL_PREFIXES}")
set(ENV{AMENT_PREFIX_PATH} "${_ament_prefix_path}")

find_package(ament_cmake REQUIRED)
# Only what rclpy uses: the C structs and the C type supports (FastDDS and introspection) under the Python
# bindings. The C++ generators, about half of the build time, are left out: nothing here is C++.
find_package(rosidl_default_generators REQUIRED)
foreach(_d IN LISTS _deps)
  find_package(${_d} REQUIRED)
endforeach()
list(FILTER AMENT_EXTENSIONS_rosidl_generate_idl_interfaces EXCLUDE REGEX "^rosidl_(generator|typesupport[a-z_]*)_cpp:")
file(GLOB _ifaces RELATIVE "${CMAKE_CURRENT_SOURCE_DIR}"
  msg/*.msg srv/*.srv action/*.action)
rosidl_generate_interfaces(${PROJECT_NAME} ${_ifaces} DEPENDENCIES ${_deps})

# The wheels were built in a manylinux container: their exported
# <pkg>::<pkg>__rosidl_generator_py targets name that container's Python and
# NumPy include dirs (/opt/python/cp311-cp311/...), which CMake rejects.
get_property(_imported DIRECTORY PROPERTY IMPORTED_TARGETS)
foreach(_t IN LISTS _imported)
  if(_t MATCHES "__rosidl_generator_py$")
    set_target_properties(${_t} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES
      "${Python3_INCLUDE_DIRS};${Python3_NumPy_INCLUDE_DIRS}")
  endif()
endforeach()

ament_export_dependencies(rosidl_default_runtime)
ament_package()
