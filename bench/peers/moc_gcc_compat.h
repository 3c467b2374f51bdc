// Force-included (g++ -include) before MOC's sources: GCC 11 and later define __cpuidex in
// <cpuid.h> and declare _xgetbv in <immintrin.h>, which MOC's CompilerSpecific.inl defines
// again for GCC. Including the system headers first and renaming MOC's copies lets its
// unmodified sources compile; MOC's code then calls its own copies under the new names.
#pragma once
#include <cpuid.h>
#include <immintrin.h>
#define __cpuidex moc_cpuidex
#define _xgetbv moc_xgetbv
