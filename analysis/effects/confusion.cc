#include "analysis/effects/confusion.h"

#include <algorithm>
#include <cmath>

#include <Eigen/QR>

#include "analysis/parallel_for.h"

namespace tribo::analysis {

namespace {

// Columns with a value that is not finite (a force not differentiable at the
// extension's neutral point) carry no direction the rival can take.
void zero_nonfinite_columns(Eigen::MatrixXd& j) {
  for (Eigen::Index c = 0; c < j.cols(); ++c) {
    if (!j.col(c).allFinite()) j.col(c).setZero();
  }
}

std::vector<int> columns_of(const ModelParams& p, Effect e) {
  std::vector<int> cols;
  for (std::size_t k = 0; k < p.specs.size(); ++k) {
    if (!p.specs[k].fixed && p.specs[k].effect == e) cols.push_back(static_cast<int>(k));
  }
  return cols;
}

// Removes from the columns of m what the decomposed columns span: with
// Q R = J, m - Q_r Q_r^T m = Q [0; (Q^T m) below the rank].
void project_off(const Eigen::ColPivHouseholderQR<Eigen::Ref<Eigen::MatrixXd>>& qr, Eigen::Ref<Eigen::MatrixXd> m) {
  if (qr.rank() == 0) return;
  m.applyOnTheLeft(qr.householderQ().adjoint());
  m.topRows(qr.rank()).setZero();
  m.applyOnTheLeft(qr.householderQ());
}

}  // namespace

EffectConfusion confusion_with_rivals(const ModelData& data, const FitResult& final_fit,
                                      const std::vector<double>& final_model, const VisibleRows& rows, Effect effect,
                                      const std::vector<Effect>& rivals, unsigned threads) {
  EffectConfusion out;
  if (!final_fit.params.structure.has(effect) || rows.fit.empty() || !(rows.sigma_fit > 0)) return out;
  const ModelParams without = without_effect(final_fit.params, effect, data);
  std::vector<double> model_without;
  Eigen::MatrixXd base = model_jacobian(data, without, without.theta, free_columns(without), rows.fit, &model_without);
  zero_nonfinite_columns(base);
  // Decomposed in place: the Jacobians are m x k, and a copy of each would
  // set the diagnosis's peak memory.
  const Eigen::ColPivHouseholderQR<Eigen::Ref<Eigen::MatrixXd>> base_qr(base);
  Eigen::VectorXd visible(static_cast<Eigen::Index>(rows.fit.size()));
  for (std::size_t r = 0; r < rows.fit.size(); ++r) {
    visible[static_cast<Eigen::Index>(r)] = final_model[rows.fit[r]] - model_without[rows.fit[r]];
  }
  std::vector<double>().swap(model_without);
  if (!visible.allFinite()) return out;
  if (base.cols() > 0) project_off(base_qr, visible);
  out.z_alone = visible_strength_z(visible, rows);
  const double power = visible.squaredNorm();

  std::vector<Effect> examined;
  for (Effect y : rivals) {
    if (y != effect && !without.structure.has(y) && std::find(examined.begin(), examined.end(), y) == examined.end()) {
      examined.push_back(y);
    }
  }
  out.rivals.resize(examined.size());
  parallel_for(examined.size(), threads, [&](std::size_t k) {
    RivalConfusion& c = out.rivals[k];
    c.rival = examined[k];
    const ModelParams extended = with_effect(without, c.rival, data);
    const std::vector<int> cols = columns_of(extended, c.rival);
    if (cols.empty()) return;
    Eigen::MatrixXd own = model_jacobian(data, extended, extended.theta, cols, rows.fit);
    zero_nonfinite_columns(own);
    // The rival's directions less what the base already spans: the
    // projection on [J_base, J_Y] of a vector orthogonal to J_base.
    if (base.cols() > 0) project_off(base_qr, own);
    const Eigen::ColPivHouseholderQR<Eigen::Ref<Eigen::MatrixXd>> own_qr(own);
    Eigen::VectorXd left = visible;
    project_off(own_qr, left);
    c.z = visible_strength_z(left, rows);
    c.explained = power > 0 ? std::clamp(1.0 - left.squaredNorm() / power, 0.0, 1.0) : std::numeric_limits<double>::quiet_NaN();
  });
  std::stable_sort(out.rivals.begin(), out.rivals.end(), [](const RivalConfusion& a, const RivalConfusion& b) {
    if (std::isnan(a.z) != std::isnan(b.z)) return std::isnan(b.z);
    return a.z < b.z;
  });
  return out;
}

}  // namespace tribo::analysis
