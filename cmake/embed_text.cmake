# Write a file's text as a NUL-terminated C array: cmake -DIN=... -DOUT=...
# -DNAME=... -P embed_text.cmake (gonio live's page, cli/live_page.html).
file(READ "${IN}" hex HEX)
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," body "${hex}")
string(REGEX REPLACE "(0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,0x..,)" "\\1\n" body "${body}")
file(WRITE "${OUT}" "/* Generated from ${IN} by cmake/embed_text.cmake. */\nconst char ${NAME}[] = {\n${body}0x00};\n")
