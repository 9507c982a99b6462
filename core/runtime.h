// Process-wide settings for the learning core.
#pragma once

#include <string>

namespace dd {

/// Sets the number of intra-op threads libtorch uses. n <= 0 picks the default: $DD_THREADS if set,
/// else 2 (this project's target machine has 2 cores). Returns the number set.
int set_num_threads(int n = 0);

/// The number of intra-op threads libtorch uses now.
int num_threads();

/// Sets the calling thread's OpenMP pool size (OpenBLAS's and oneDNN's kernels), without touching
/// libtorch's setting; nothing in a program without OpenMP. A pool does not survive fork, and each
/// thread has its own.
void set_openmp_threads(int n);

/// Work that splits in two (a training step's minibatch, a data set's pairs when setting a threshold,
/// a batch of independent rollouts)
/// runs in two processes of one thread each when this process has two threads or more (the default,
/// on), or in this process's threads (off). A step of libtorch operators uses a second thread
/// poorly; a second process, nearly fully. Both give the same numbers up to float rounding.
void set_data_parallel(bool on);
/// The command line's choice: off when `one_process` is true or $DD_ONE_PROCESS is set to anything
/// but "" or "0"; on otherwise. Returns the setting.
bool set_data_parallel_from(bool one_process);
/// Whether to split now: set_data_parallel on, two threads or more, and not inside a parallel region.
bool split_in_two_processes();

/// A folder in which PolicyEnsemble::train keeps the members it trains, keyed by everything the
/// training reads (core/ensemble.h), so that training the same members on the same data again loads
/// them instead: Ensemble-DAgger and Thrifty-DAgger train the very same ensemble until their queries
/// first differ. "" (the default) keeps nothing. eval sets OUT/runs/ensemble_cache.
void set_ensemble_train_cache(const std::string& dir);
std::string ensemble_train_cache();

}  // namespace dd
