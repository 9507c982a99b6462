// Process-wide settings for the learning core.
#pragma once

namespace dd {

/// Sets the number of intra-op threads libtorch uses. n <= 0 picks the default: $DD_THREADS if set,
/// else 2 (this project's target machine has 2 cores). Returns the number set.
int set_num_threads(int n = 0);

/// The number of intra-op threads libtorch uses now.
int num_threads();

}  // namespace dd
