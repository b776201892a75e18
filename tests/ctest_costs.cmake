# Included by ctest after the discovered gtest tests (TEST_INCLUDE_FILES in CMakeLists.txt,
# which sets the COST of the tests it declares itself): the longest tests, with the seconds
# each took in one `ctest -j2` run on the 2-core machine shared with other jobs (3 Dec 2026,
# load 3-6; only their order matters), as ctest's COST. ctest starts the tests in
# decreasing COST, so a fresh build, which has no measured costs yet, starts these first
# instead of in declaration order (where a one-minute test could start last and run alone
# at the end).
foreach(entry
    "DemoCli.WholeChainOnASmallPair 56"
    "ElasticCli.DefaultBendingWeightLeavesTheBasinOfAFlippedBimMap 43"
    "ElasticCli.SymmetricRunWritesOutputsAndEvaluateReportsSec61Metrics 38"
    "BallParamCreature.StalledCgFallsBackToTheInputLaplacian 38"
    "VolumeMapCli.PostRepairFallbackRemovesTheLastInvertedTets 22")
  string(REPLACE " " ";" entry "${entry}")
  list(GET entry 0 name)
  list(GET entry 1 cost)
  set_tests_properties(${name} PROPERTIES COST ${cost})
endforeach()
