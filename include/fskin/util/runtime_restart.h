#pragma once
// Settings the runtime libraries read only once, when they are loaded, applied
// by restarting the program once with them in its environment:
// - OPENBLAS_CORETYPE (blas_kernels.h): the better BLAS kernels where Debian's
//   OpenBLAS falls back to SSE3 ones.
// - GOMP_SPINCOUNT (openmp_wait.h): how long an idle OpenMP thread spins
//   before it sleeps. libgomp's default spin (300,000 pause loops, ~10-20 ms
//   on current Xeons) is spent at every barrier whose partner thread is
//   descheduled, so training next to another busy process ran 20x slower.
// Variables the user set are respected and never overridden.
#include <string>
#include <utility>
#include <vector>

namespace fskin {

using EnvironmentSettings = std::vector<std::pair<std::string, std::string>>;

// What a restart would set: the OpenBLAS kernels always (they matter for
// every command that multiplies), the OpenMP wait only for `long_running`
// commands (training, evaluation, meshing, benchmarks), which share the
// machine long enough for it to matter and to amortise the restart.
EnvironmentSettings runtime_settings(bool long_running);

// Whether the command line names a long-running subcommand (train, eval,
// mesh, animate, data, bench).
bool is_long_running_command(int argc, char** argv);

// Call first thing in main(): when runtime_settings(long_running) is not
// empty, re-executes the running program (/proc/self/exe, same arguments) with
// them set; returns only when there was nothing to do or exec failed (then the
// environment is as it was). The restart costs ~0.8 s (LibTorch loads twice).
void restart_with_runtime_settings(char** argv, bool long_running);

}  // namespace fskin
