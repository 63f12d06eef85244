#pragma once

// The QR factorisation Eigen's LevenbergMarquardt asks of its functor's
// QRSolver type (LMonestep.h, LMpar.h, LMqrsolv.h of Eigen 3.4), for the
// tall Jacobian of a friction fit: m fit samples (up to about a million)
// by k free parameters (5-20).
//
// The step reads of the factorisation only the k x k triangular factor R,
// the column permutation, the rank, and the first k entries of Q^T f, f the
// residual at the point the Jacobian J was taken. A column-pivoted
// Householder QR of J itself applies k reflectors each to the whole m x k
// matrix: k passes over memory that does not fit in cache (a fifth of the
// CPU time of a diagnosis of a 3071 s record at 1 kHz). Here [J f] is
// reduced to a (k+1) x (k+1) triangle chunk by chunk of rows, each chunk's
// reflectors applied while it is in cache (one pass over J), and the
// column-pivoted QR is taken of that triangle: J = Q1 R and R P = Q2 R'
// give J P = (Q1 Q2) R', the same factorisation in exact arithmetic, its
// pivots chosen on the same column norms (Q1 keeps them), the rank on the
// same threshold (machine epsilon times k, times the largest pivot).
//
// J is read, not changed: once factorised its storage is free for the
// trial points' Jacobians.

#include <Eigen/Dense>

namespace tribo::analysis {

class ChunkedQR {
 public:
  using MatrixType = Eigen::MatrixXd;
  using Scalar = double;
  using RealScalar = double;
  using StorageIndex = MatrixType::StorageIndex;
  using PermutationType = Eigen::ColPivHouseholderQR<MatrixType>::PermutationType;

  // The residual f that goes with the Jacobian the solver factorises on this
  // thread while the scope lives (the solver's own fvec: Eigen constructs
  // the QRSolver from the Jacobian alone).
  class ResidualScope {
   public:
    ResidualScope(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residual);
    ~ResidualScope();
    ResidualScope(const ResidualScope&) = delete;
    ResidualScope& operator=(const ResidualScope&) = delete;

   private:
    friend class ChunkedQR;
    const Eigen::MatrixXd& jacobian_;
    const Eigen::VectorXd& residual_;
    const ResidualScope* enclosing_;
  };

  // Q^T v for the step's v = f: an m-vector whose first k entries are
  // (Q^T f)'s, the rest zero (the step reads only those k), as an
  // expression: assigned, it writes into the step's own vector.
  struct PaddedQtf {
    const Eigen::VectorXd* qtf;
    double operator()(Eigen::Index i) const { return i < qtf->size() ? (*qtf)[i] : 0.0; }
  };
  struct QAdjoint {
    const ChunkedQR& qr;
    Eigen::CwiseNullaryOp<PaddedQtf, Eigen::VectorXd> operator*(const Eigen::VectorXd& v) const;
  };
  struct QFactor {
    const ChunkedQR& qr;
    QAdjoint adjoint() const { return {qr}; }
  };

  // Throws std::logic_error without a ResidualScope for jacobian.
  explicit ChunkedQR(const Eigen::MatrixXd& jacobian);

  // R' in the upper triangle (below it, the k x k QR's reflectors: the
  // step reads the upper triangle only).
  const Eigen::MatrixXd& matrixR() const { return pivoted_.matrixQR(); }
  const PermutationType& colsPermutation() const { return pivoted_.colsPermutation(); }
  Eigen::Index rank() const { return pivoted_.rank(); }
  Eigen::ComputationInfo info() const { return pivoted_.info(); }
  QFactor matrixQ() const { return {*this}; }

  // Rows of [J f] reduced at a time: a chunk of 512 x (k+1) doubles is 84 kB
  // at k = 20, in a core's own cache.
  static constexpr Eigen::Index kChunkRows = 512;

 private:
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> pivoted_;
  Eigen::VectorXd qtf_;  // the first k entries of Q^T f
  const double* residual_data_ = nullptr;
  Eigen::Index residual_size_ = 0;
};

// The (k+1) x (k+1) upper triangle T of [J f] (T^T T = [J f]^T [J f]),
// reduced by Householder reflectors chunk by chunk of rows; its top-left
// k x k block is R, its last column's first k entries Q1^T f.
Eigen::MatrixXd chunked_triangle(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residual);

}  // namespace tribo::analysis
