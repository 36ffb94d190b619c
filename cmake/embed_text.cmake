# Writes a C++ source defining `std::string_view NAMESPACE::FUNCTION()` that returns the text of
# INPUT, as raw string literals (run with cmake -P: -DINPUT=... -DOUTPUT=... -DNAMESPACE=...
# -DFUNCTION=...).
file(READ "${INPUT}" text)
set(delimiter "cutsim_embed")
string(FIND "${text}" ")${delimiter}\"" clash)
if(NOT clash EQUAL -1)
  message(FATAL_ERROR "${INPUT} contains the raw string delimiter )${delimiter}\"")
endif()
string(LENGTH "${text}" length)
# Pieces of at most 60000 characters, each its own literal (joined by the compiler).
set(pieces "")
set(at 0)
while(at LESS length)
  string(SUBSTRING "${text}" ${at} 60000 piece)
  string(APPEND pieces "R\"${delimiter}(${piece})${delimiter}\"\n")
  math(EXPR at "${at} + 60000")
endwhile()
if(pieces STREQUAL "")
  set(pieces "\"\"")
endif()
file(WRITE "${OUTPUT}.tmp" "// Generated from ${INPUT} by cmake/embed_text.cmake: do not edit.\n#include <string_view>\n\nnamespace ${NAMESPACE} {\nnamespace {\nconstexpr char kText[] =\n${pieces};\n}  // namespace\nstd::string_view ${FUNCTION}() { return {kText, sizeof(kText) - 1}; }\n}  // namespace ${NAMESPACE}\n")
file(RENAME "${OUTPUT}.tmp" "${OUTPUT}")
