#include "analysis/models/chunked_qr.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace tribo::analysis {

namespace {

thread_local const ChunkedQR::ResidualScope* active_scope = nullptr;

// Reflects a chunk of rows into the triangle: column j's reflector acts on
// the triangle's row j and the chunk's rows only, since the triangle's rows
// below j are already zero in column j.
void reduce_chunk(Eigen::MatrixXd& triangle, Eigen::Ref<Eigen::MatrixXd> chunk) {
  const Eigen::Index columns = triangle.cols();
  for (Eigen::Index j = 0; j < columns; ++j) {
    const auto tail = chunk.col(j);
    const double sigma = tail.squaredNorm();
    if (sigma == 0) continue;
    const double x0 = triangle(j, j);
    const double norm = std::sqrt(x0 * x0 + sigma);
    // The sign that keeps v0 = x0 - beta away from cancellation.
    const double beta = x0 >= 0 ? -norm : norm;
    const double v0 = x0 - beta;
    // H = I - 2 v v^T / (v^T v) with v = [v0; tail] and v^T v = -2 beta v0.
    const double scale = 1.0 / (beta * v0);
    triangle(j, j) = beta;
    for (Eigen::Index c = j + 1; c < columns; ++c) {
      const double s = (v0 * triangle(j, c) + tail.dot(chunk.col(c))) * scale;
      triangle(j, c) += s * v0;
      chunk.col(c) += s * tail;
    }
  }
}

}  // namespace

Eigen::MatrixXd chunked_triangle(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residual) {
  const Eigen::Index m = jacobian.rows(), k = jacobian.cols();
  if (residual.size() != m) throw std::invalid_argument("chunked_triangle: the residual's length is not the Jacobian's rows");
  Eigen::MatrixXd triangle = Eigen::MatrixXd::Zero(k + 1, k + 1);
  Eigen::MatrixXd chunk(std::min(ChunkedQR::kChunkRows, m), k + 1);
  for (Eigen::Index first = 0; first < m; first += ChunkedQR::kChunkRows) {
    const Eigen::Index rows = std::min(ChunkedQR::kChunkRows, m - first);
    chunk.topLeftCorner(rows, k) = jacobian.middleRows(first, rows);
    chunk.col(k).head(rows) = residual.segment(first, rows);
    reduce_chunk(triangle, chunk.topRows(rows));
  }
  return triangle;
}

ChunkedQR::ResidualScope::ResidualScope(const Eigen::MatrixXd& jacobian, const Eigen::VectorXd& residual)
    : jacobian_(jacobian), residual_(residual), enclosing_(active_scope) {
  active_scope = this;
}

ChunkedQR::ResidualScope::~ResidualScope() { active_scope = enclosing_; }

ChunkedQR::ChunkedQR(const Eigen::MatrixXd& jacobian) {
  const ResidualScope* scope = active_scope;
  if (!scope || &scope->jacobian_ != &jacobian) {
    throw std::logic_error("ChunkedQR: no residual goes with this Jacobian (a ResidualScope must enclose the solve)");
  }
  const Eigen::VectorXd& residual = scope->residual_;
  const Eigen::Index k = jacobian.cols();
  const Eigen::MatrixXd triangle = chunked_triangle(jacobian, residual);
  pivoted_.compute(triangle.topLeftCorner(k, k));
  qtf_ = pivoted_.householderQ().adjoint() * triangle.col(k).head(k);
  residual_data_ = residual.data();
  residual_size_ = residual.size();
}

Eigen::CwiseNullaryOp<ChunkedQR::PaddedQtf, Eigen::VectorXd> ChunkedQR::QAdjoint::operator*(const Eigen::VectorXd& v) const {
  if (v.data() != qr.residual_data_ || v.size() != qr.residual_size_) {
    throw std::logic_error("ChunkedQR: Q^T is formed only for the residual factorised with the Jacobian");
  }
  return Eigen::VectorXd::NullaryExpr(v.size(), PaddedQtf{&qr.qtf_});
}

}  // namespace tribo::analysis
