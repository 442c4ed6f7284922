# evidence.cmake — the accuracy/cost sweeps, stability stress tests,
# and the paper's Table 2 and Fig. 17, as programs that tools/evidence/run.sh
# runs (never from ctest; tests/test_evidence_*.c keep one small instance each);
# flip: the flip transfer against APIC (energy kept, cost, work–precision).
foreach(prog accuracy stability energy table2 flip)
  add_executable(kf_evid_${prog} ${CMAKE_CURRENT_LIST_DIR}/${prog}.c)
  target_link_libraries(kf_evid_${prog} PRIVATE kerf_core)
endforeach()

# water at rest in a tank: its level over time
add_executable(kf_evid_tank_rest ${CMAKE_CURRENT_LIST_DIR}/tank_rest.c)
target_link_libraries(kf_evid_tank_rest PRIVATE kerf_core)

# orange peel: flatness, edges, volume and sheet holes of a surfaced jittered block
add_executable(kf_evid_surface_look ${CMAKE_CURRENT_LIST_DIR}/surface_look.c)
target_link_libraries(kf_evid_surface_look PRIVATE kerf_core)
target_compile_definitions(kf_evid_surface_look PRIVATE KERF_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
