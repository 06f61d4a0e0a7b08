# Writes damaged copies of the demo session for replay_localize's edge tests (cmake -P, with
# -DDEMO=<demo session> -DMAP=<its map> -DOUT=<folder>):
#   truncated.session   the last record cut off mid-line, as a crash while writing leaves it
#   extreme_t.session   the first pose at t_ns = 2^63 - 1 (signed overflow in every difference)
#   folder_map.session  a 'map' line naming a folder
file(MAKE_DIRECTORY "${OUT}/a_folder")
file(COPY "${MAP}" DESTINATION "${OUT}")
file(READ "${DEMO}" demo)
string(LENGTH "${demo}" n)
math(EXPR cut "${n} - 25")
string(SUBSTRING "${demo}" 0 ${cut} truncated)
file(WRITE "${OUT}/truncated.session" "${truncated}")
string(REPLACE "\npose 5000000000000 " "\npose 9223372036854775807 " extreme "${demo}")
file(WRITE "${OUT}/extreme_t.session" "${extreme}")
string(REPLACE "\nmap replay_demo_map.pgm\n" "\nmap a_folder\n" folder "${demo}")
file(WRITE "${OUT}/folder_map.session" "${folder}")
