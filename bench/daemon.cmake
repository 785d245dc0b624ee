# Per-tick cost of coopdynd's loop and codec (Google Benchmark). Loop timing in place, with
# cyclictest next to it, is bench/loop_timing.sh. Included at the end of bench/CMakeLists.txt.
add_executable(loop_bench ${CMAKE_CURRENT_LIST_DIR}/loop_bench.cc)
target_link_libraries(loop_bench PRIVATE coopdyn_runtime coopdyn_scene benchmark::benchmark)
coopdyn_use_paths(loop_bench)

# Two processes that only talk LCM: the transport's share of the event-driven latency (loop_timing.sh)
add_executable(lcm_pingpong ${CMAKE_CURRENT_LIST_DIR}/lcm_pingpong.cc)
target_link_libraries(lcm_pingpong PRIVATE coopdyn_io)

# The MAC check of an authenticated input, per message of each input type (bench/README.md,
# "Commands under a flood of junk")
add_executable(auth_bench ${CMAKE_CURRENT_LIST_DIR}/auth_bench.cc)
target_link_libraries(auth_bench PRIVATE coopdyn_io coopdyn_scene benchmark::benchmark)
coopdyn_use_paths(auth_bench)

# Decoding a measured state: the allocation-free decoder the loop runs on arrival against the
# generated one (service/io/codec/direct_decoder.h)
add_executable(direct_decoder_bench ${CMAKE_CURRENT_LIST_DIR}/direct_decoder_bench.cc)
target_link_libraries(direct_decoder_bench PRIVATE coopdyn_io coopdyn_scene benchmark::benchmark)
coopdyn_use_paths(direct_decoder_bench)
