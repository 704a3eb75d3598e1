# Turns a binary file into a C++ source holding its bytes (build-time step, so
# the default vocabulary ships inside the library and needs no install path).
#   cmake -DIN=<file> -DOUT=<file.cpp> -DNAME=<symbol> -P embed.cmake
# A missing IN gives an empty array (a build before any vocabulary exists).
if(EXISTS "${IN}")
  file(READ "${IN}" hex HEX)
else()
  set(hex "")
endif()
string(LENGTH "${hex}" n)
math(EXPR bytes "${n} / 2")
# 32 bytes (64 hex digits) per line, then each byte as 0xNN.
string(REGEX REPLACE "(................................................................)" "\\1\n" hex "${hex}")
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," body "${hex}")
if(bytes EQUAL 0)
  set(body "0")
endif()
file(WRITE "${OUT}.tmp" "// Generated from ${IN} by embed.cmake. Do not edit.\n#include <cstddef>\nnamespace rost::vision::detail {\nextern const unsigned char ${NAME}[];\nextern const std::size_t ${NAME}Size;\nalignas(32) const unsigned char ${NAME}[] = {\n${body}};\nconst std::size_t ${NAME}Size = ${bytes};\n}\n")
file(RENAME "${OUT}.tmp" "${OUT}")
