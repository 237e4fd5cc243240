#pragma once
// The process's CPU time (all threads), for benchmarks on a shared machine: wall-clock figures
// include time the scheduler gave to someone else; CPU time divided by the worker count is what
// the work would take on idle cores.

namespace parallax {

// Milliseconds of CPU time this process has used so far (CLOCK_PROCESS_CPUTIME_ID).
double processCpuMs();

}  // namespace parallax
