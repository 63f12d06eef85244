// X^T X for a regression whose columns are given as arrays over the samples,
// each element summed over the samples in their order, as a rank-one update
// per sample (Eigen's selfadjointView().rankUpdate(row), sample after sample)
// sums it: the same products, added in the same order, so the same matrix bit
// for bit. The loop model's reference taps are nearly collinear, and a sum in
// another order (a GEMM's blocks, sums shifted along the windows) moved the
// final model of an 800 s record past its standard errors
// (analysis/motion/motion_estimate.cc).
//
// Cheaper than the rank-one updates: a tile of the matrix stays in registers
// over a chunk of samples instead of the whole triangle being read and written
// back for every sample.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace tribo::analysis {

// columns[c][i]: column c at sample i, for i in [0, samples). Returns the full
// symmetric matrix (columns.size() square), the same bits on any number of
// threads (0: one per core).
Eigen::MatrixXd gram_in_sample_order(const std::vector<const double*>& columns, std::size_t samples,
                                     unsigned threads = 1);

}  // namespace tribo::analysis
