# SPDX-License-Identifier: Apache-2.0
# Script mode: -DIN=<file.cl> -DOUT=<file.cpp> -DNAME=<name>. Inlines local includes, then
# writes the text as a C++ raw string literal. (file(READ), not file(STRINGS): the latter
# splits lines at ';'.)
function(vfit_inline_includes path out_var depth)
  if(depth GREATER 8)
    message(FATAL_ERROR "embed_cl: include nesting too deep at ${path}")
  endif()
  get_filename_component(dir "${path}" DIRECTORY)
  file(READ "${path}" text)
  string(REGEX MATCHALL "#[ \t]*include[ \t]*\"[^\"]+\"" includes "${text}")
  foreach(inc IN LISTS includes)
    string(REGEX REPLACE "#[ \t]*include[ \t]*\"([^\"]+)\"" "\\1" name "${inc}")
    math(EXPR next "${depth} + 1")
    vfit_inline_includes("${dir}/${name}" inner ${next})
    string(REPLACE "${inc}" "${inner}" text "${text}")
  endforeach()
  set(${out_var} "${text}" PARENT_SCOPE)
endfunction()

vfit_inline_includes("${IN}" body 0)
file(WRITE "${OUT}.tmp" "// Generated from ${NAME}.cl by cmake/embed_cl_file.cmake.\nextern const char* const vfit_cl_${NAME};\nconst char* const vfit_cl_${NAME} = R\"VFITCL(\n${body})VFITCL\";\n")
file(RENAME "${OUT}.tmp" "${OUT}")
