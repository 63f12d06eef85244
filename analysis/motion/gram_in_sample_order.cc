#include "analysis/motion/gram_in_sample_order.h"

#include <algorithm>
#include <thread>

#include "analysis/parallel_for.h"

namespace tribo::analysis {

namespace {

// A tile is 4 x 4 elements (eight SSE2 registers of sums); a chunk of
// samples is read once per tile while it stays in the cache.
constexpr std::size_t kTile = 4;
constexpr std::size_t kChunk = 1024;

// out's 4 x 4 tile (column-major, leading dimension stride) += the products
// of the columns rows[0..3] and cols[0..3] over samples [first, last), each
// element summed in sample order: sum + row * col, as a rank-one update adds.
void accumulate_tile(const double* const* rows, const double* const* cols, std::size_t first, std::size_t last,
                     double* out, std::size_t stride) {
  using Column = Eigen::Array4d;
  Eigen::Map<Column> out0(out), out1(out + stride), out2(out + 2 * stride), out3(out + 3 * stride);
  Column sum0 = out0, sum1 = out1, sum2 = out2, sum3 = out3;
  const double *r0 = rows[0], *r1 = rows[1], *r2 = rows[2], *r3 = rows[3];
  const double *c0 = cols[0], *c1 = cols[1], *c2 = cols[2], *c3 = cols[3];
  for (std::size_t s = first; s < last; ++s) {
    const Column x(r0[s], r1[s], r2[s], r3[s]);
    sum0 += x * c0[s];
    sum1 += x * c1[s];
    sum2 += x * c2[s];
    sum3 += x * c3[s];
  }
  out0 = sum0;
  out1 = sum1;
  out2 = sum2;
  out3 = sum3;
}

}  // namespace

Eigen::MatrixXd gram_in_sample_order(const std::vector<const double*>& columns, std::size_t samples, unsigned threads) {
  const std::size_t count = columns.size();
  if (count == 0) return Eigen::MatrixXd(0, 0);
  // Whole tiles: the padding columns repeat the last one; their sums are
  // computed and never read.
  const std::size_t padded = (count + kTile - 1) / kTile * kTile;
  std::vector<const double*> column(columns);
  column.resize(padded, columns.back());
  const auto size = static_cast<Eigen::Index>(padded);
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(size, size);
  // The columns of tiles dealt out to the jobs in turn (the triangle's long
  // and short columns alike); each job reads a chunk once for all its tiles,
  // and each tile is summed by one job over the chunks in order, so the
  // schedule changes no bit.
  const std::size_t tiles = padded / kTile;
  const std::size_t jobs = std::min<std::size_t>(
      tiles, threads == 0 ? std::max(1u, std::thread::hardware_concurrency()) : threads);
  parallel_for(jobs, static_cast<unsigned>(jobs), [&](std::size_t job) {
    for (std::size_t first = 0; first < samples; first += kChunk) {
      const std::size_t last = std::min(samples, first + kChunk);
      for (std::size_t b = job * kTile; b < padded; b += jobs * kTile) {
        for (std::size_t a = b; a < padded; a += kTile) {
          accumulate_tile(column.data() + a, column.data() + b, first, last,
                          &sum(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b)), padded);
        }
      }
    }
  });
  const auto n = static_cast<Eigen::Index>(count);
  Eigen::MatrixXd gram(n, n);
  gram = sum.topLeftCorner(n, n).selfadjointView<Eigen::Lower>();
  return gram;
}

}  // namespace tribo::analysis
