# cmake -DINPUT=page.html -DOUTPUT=page.inc -P embed_text.cmake: the file as a C++ string literal, in chunks (a
# compiler may limit one literal's length) of hex escapes, so no character of the page needs care.
file(READ ${INPUT} hex HEX)
string(LENGTH "${hex}" n)
set(out "// Generated from ${INPUT} by embed_text.cmake; do not edit.\n")
string(APPEND out "static const unsigned char kDashboardPage[] = {\n")
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
string(REGEX REPLACE "((0x..,){32})" "\\1\n" bytes "${bytes}")
string(APPEND out "${bytes}0x00};\n")
file(WRITE ${OUTPUT}.tmp "${out}")
file(COPY_FILE ${OUTPUT}.tmp ${OUTPUT} ONLY_IF_DIFFERENT)
file(REMOVE ${OUTPUT}.tmp)
