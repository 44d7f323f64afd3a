# Warnings per target (house style); -Werror when the CI environment variable is set.
function(shape_slam_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow)
  if(DEFINED ENV{CI} AND NOT "$ENV{CI}" STREQUAL "" AND NOT "$ENV{CI}" STREQUAL "false")
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
