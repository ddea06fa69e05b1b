# One place for the language level and warnings every target uses.
include_guard(GLOBAL)

function(terrain_set_project_options target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  set_target_properties(${target} PROPERTIES CXX_EXTENSIONS OFF)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wconversion -Wshadow -Wpedantic -Werror
    # Same numbers on every compiler: no fused multiply-add contraction.
    -ffp-contract=off
    # Nothing reads errno after maths calls; without this GCC keeps a scalar call path around
    # every sqrt, which stops loops over points from vectorising. Results are unchanged.
    -fno-math-errno
    # Nothing reads the floating-point exception flags either; with them GCC will not compute
    # both sides of a select, so branch-free loops (drawing a drainage floor along a row of
    # samples) stay scalar. Values are unchanged: no reassociation, no contraction.
    -fno-trapping-math
    # GCC 12 at -O3 reports impossible std::string overlaps (GCC bug 105329): a false positive.
    $<$<CXX_COMPILER_ID:GNU>:-Wno-restrict>
    # Clang's -Wconversion also warns on signedness, which GCC's (the reference) does not; the
    # fuzz preset builds with Clang.
    $<$<CXX_COMPILER_ID:Clang>:-Wno-sign-conversion>)
endfunction()
