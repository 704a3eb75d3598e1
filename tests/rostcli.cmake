# rost-cli's drop-in commands (issue 15): a rost-cli user's pipeline end to
# end through the executables (topics.refine.t, topics.refine.txy,
# words.bincount), whose paths the test gets as compile definitions.
if(NOT TARGET rostcli_topics_refine_t)
  return()
endif()
rost_add_test(test_rostcli SOURCES test_rostcli.cpp test_rostcli_online.cpp TIMED)
target_compile_definitions(test_rostcli PRIVATE
  ROSTCLI_REFINE_T="$<TARGET_FILE:rostcli_topics_refine_t>"
  ROSTCLI_REFINE_TXY="$<TARGET_FILE:rostcli_topics_refine_txy>"
  ROSTCLI_BINCOUNT="$<TARGET_FILE:rostcli_words_bincount>")
add_dependencies(test_rostcli rostcli_topics_refine_t rostcli_topics_refine_txy rostcli_words_bincount)
