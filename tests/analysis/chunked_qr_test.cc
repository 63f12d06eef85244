// The QR the model fit's Levenberg-Marquardt steps factorise with
// (analysis/models/chunked_qr.h), against Eigen's column-pivoted Householder
// QR of the whole tall matrix.
#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

#include "analysis/models/chunked_qr.h"

namespace tribo::analysis {
namespace {

// A tall matrix over several chunks and a part one, with columns of very
// different norms (as the normalised parameters' are) and two nearly
// collinear ones.
Eigen::MatrixXd tall_jacobian(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd j(rows, cols);
  for (Eigen::Index c = 0; c < cols; ++c) {
    const double scale = std::pow(10.0, static_cast<double>(c % 5) - 2.0);
    for (Eigen::Index r = 0; r < rows; ++r) j(r, c) = scale * normal(rng);
  }
  j.col(cols - 1) = j.col(0) * 3.0 + 1e-6 * j.col(cols - 1);
  return j;
}

Eigen::VectorXd residual_of(Eigen::Index rows, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  Eigen::VectorXd f(rows);
  for (Eigen::Index r = 0; r < rows; ++r) f[r] = normal(rng);
  return f;
}

TEST(ChunkedQR, TheTriangleHasTheGramMatrixOfTheJacobianAndResidual) {
  const Eigen::Index m = 3 * ChunkedQR::kChunkRows + 77, k = 7;
  const Eigen::MatrixXd j = tall_jacobian(m, k, 1);
  const Eigen::VectorXd f = residual_of(m, 2);
  const Eigen::MatrixXd t = chunked_triangle(j, f);
  ASSERT_EQ(t.rows(), k + 1);
  ASSERT_EQ(t.cols(), k + 1);
  EXPECT_EQ(t.triangularView<Eigen::StrictlyLower>().toDenseMatrix().cwiseAbs().maxCoeff(), 0.0);
  Eigen::MatrixXd a(m, k + 1);
  a << j, f;
  const Eigen::MatrixXd gram = a.transpose() * a;
  const Eigen::MatrixXd from_triangle = t.transpose() * t;
  EXPECT_LT((from_triangle - gram).cwiseAbs().maxCoeff(), 1e-12 * gram.cwiseAbs().maxCoeff());
}

TEST(ChunkedQR, GivesTheStepWhatEigensPivotedQROfTheWholeMatrixGives) {
  const Eigen::Index m = 2 * ChunkedQR::kChunkRows + 300, k = 6;
  Eigen::MatrixXd j = tall_jacobian(m, k, 3);
  j.col(k - 1) = tall_jacobian(m, k, 4).col(2);  // full rank here
  const Eigen::VectorXd f = residual_of(m, 5);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> whole(j);
  const ChunkedQR::ResidualScope scope(j, f);
  const ChunkedQR chunked(j);
  EXPECT_EQ(chunked.rank(), whole.rank());
  EXPECT_EQ(chunked.colsPermutation().indices(), whole.colsPermutation().indices());
  // R' is unique up to the sign of each row; Q^T f's rows carry the same signs.
  const Eigen::MatrixXd r_whole = whole.matrixR().topRows(k).triangularView<Eigen::Upper>();
  const Eigen::MatrixXd r_chunked = chunked.matrixR().triangularView<Eigen::Upper>();
  const Eigen::VectorXd qtf_whole = (whole.householderQ().adjoint() * f).head(k);
  const Eigen::VectorXd qtf_chunked = (chunked.matrixQ().adjoint() * f);
  ASSERT_EQ(qtf_chunked.size(), m);
  EXPECT_EQ(qtf_chunked.tail(m - k).cwiseAbs().maxCoeff(), 0.0);
  for (Eigen::Index row = 0; row < k; ++row) {
    const double sign = r_whole(row, row) * r_chunked(row, row) < 0 ? -1.0 : 1.0;
    EXPECT_LT((sign * r_chunked.row(row) - r_whole.row(row)).cwiseAbs().maxCoeff(), 1e-10 * r_whole.cwiseAbs().maxCoeff()) << row;
    EXPECT_NEAR(sign * qtf_chunked[row], qtf_whole[row], 1e-10 * qtf_whole.cwiseAbs().maxCoeff()) << row;
  }
  // The least-squares step both give.
  const Eigen::MatrixXd r_upper = r_chunked;
  const Eigen::VectorXd qtf_head = qtf_chunked.head(k);
  Eigen::VectorXd permuted_step = r_upper.triangularView<Eigen::Upper>().solve(qtf_head);
  const Eigen::VectorXd step = chunked.colsPermutation() * permuted_step;
  const Eigen::VectorXd expected = whole.solve(f);
  EXPECT_LT((step - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff());
}

TEST(ChunkedQR, ACollinearColumnLowersTheRankAsInEigensQR) {
  const Eigen::Index m = ChunkedQR::kChunkRows + 5, k = 5;
  Eigen::MatrixXd j = tall_jacobian(m, k, 6);
  j.col(k - 1) = 2.0 * j.col(1);  // exactly collinear
  const Eigen::VectorXd f = residual_of(m, 7);
  const ChunkedQR::ResidualScope scope(j, f);
  const ChunkedQR chunked(j);
  EXPECT_EQ(chunked.rank(), Eigen::ColPivHouseholderQR<Eigen::MatrixXd>(j).rank());
  EXPECT_EQ(chunked.rank(), k - 1);
}

TEST(ChunkedQR, RefusesAJacobianWithoutItsResidualAndAnotherVector) {
  const Eigen::MatrixXd j = tall_jacobian(100, 3, 8);
  const Eigen::VectorXd f = residual_of(100, 9);
  EXPECT_THROW(ChunkedQR{j}, std::logic_error);
  const ChunkedQR::ResidualScope scope(j, f);
  const ChunkedQR chunked(j);
  const Eigen::VectorXd other = f;
  EXPECT_THROW(chunked.matrixQ().adjoint() * other, std::logic_error);
}

}  // namespace
}  // namespace tribo::analysis
