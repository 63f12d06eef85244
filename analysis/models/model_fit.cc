#include "analysis/models/model_fit.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdint>
#include <type_traits>
#include <cmath>
#include <map>
#include <limits>
#include <stdexcept>
#include <cstdio>
#include <cstdlib>

#include <Eigen/Dense>
#include <unsupported/Eigen/LevenbergMarquardt>

#include "analysis/models/autodiff.h"
#include "analysis/models/chunked_qr.h"
#include "analysis/parallel_for.h"

namespace tribo::analysis {

namespace {

// The samples that are rows of the Jacobian and the residual, in time
// order: a list of indices, or a mask (the fit's: no index array per fit).
struct RowSelection {
  const std::vector<std::size_t>* list = nullptr;
  const std::vector<char>* mask = nullptr;
  std::size_t count = 0;
  bool selects(std::size_t i, std::size_t r) const { return mask ? (*mask)[i] != 0 : r < count && (*list)[r] == i; }
};

void jacobian_rows(const ModelData& data, const ModelParams& params, const std::vector<double>& theta,
                   const std::vector<int>& columns, const RowSelection& rows, double sign,
                   Eigen::Ref<Eigen::MatrixXd> out, std::vector<double>* model, Eigen::VectorXd* residual);

// Eigen's LM functor over the free parameters; residual = measured - model.
// Residual and Jacobian rows are streamed from the simulation into the
// solver's own vectors (no per-sample model array).
//
// A trial point is evaluated with its Jacobian whenever the solver holds m x k
// storage no one reads at that moment (the first point, in minimizeInit; each
// trial of a step, whose factorisation has read J already): an accepted
// trial is the next step's point, and its Jacobian is then already in place
// (df). The autodiff simulation computes the same force values as the
// double one, bit for bit (value_of() decides every branch), so the
// residuals are the same. This saves the plain evaluation of every accepted
// step (and of the fit's last point) at the price of the derivatives of
// every rejected one: diagnose() on the 200 s benchmark run, 12.8 -> 11.4 s
// of CPU, the report bit for bit the same.
struct ModelFunctor : Eigen::DenseFunctor<double> {
  // Eigen's default QR would copy the m x k Jacobian each step and hand out
  // an m x k R; this one reads J in chunks and keeps k x k (chunked_qr.h).
  using QRSolver = ChunkedQR;

  ModelFunctor(const ModelData& d, const ModelParams& p, const std::vector<char>& in_fit, std::size_t count,
               std::vector<int> free)
      : Eigen::DenseFunctor<double>(static_cast<int>(free.size()), static_cast<int>(count)),
        data(d), params(p), rows{nullptr, &in_fit, count}, free(std::move(free)) {}

  // The solver's variables are theta + kShift: MINPACK sizes its first trust
  // region as factor * |x|, which is zero when every parameter starts at its
  // own scale (theta = 0); shifted, the first step is of order one.
  static constexpr double kShift = 1.0;

  std::vector<double> full_theta(const Eigen::VectorXd& x) const {
    std::vector<double> theta = params.theta;
    for (std::size_t j = 0; j < free.size(); ++j) theta[static_cast<std::size_t>(free[j])] = x[static_cast<Eigen::Index>(j)] - kShift;
    return theta;
  }

  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& fvec) const {
    if (Eigen::MatrixXd* free_storage = trial_storage()) {
      jacobian_rows(data, params, full_theta(x), free, rows, -1.0, *free_storage, nullptr, &fvec);
      trial_jacobian = free_storage->data();
      trial_x = x;
      return 0;
    }
    std::size_t r = 0;
    const std::vector<double>& measured = *data.fitted_force;
    auto residual = [&](std::size_t i, const double& force, const double&) {
      if (!rows.selects(i, r)) return;
      const double e = measured[i] - force;
      fvec[static_cast<Eigen::Index>(r++)] = std::isfinite(e) ? e : 1e30;
    };
    simulate_streamed<double>(data, params, full_theta(x), SampleSink<double>(residual, rows.mask));
    return 0;
  }

  int df(const Eigen::VectorXd& x, Eigen::MatrixXd& fjac) const {
    const auto m = static_cast<Eigen::Index>(rows.count), k = static_cast<Eigen::Index>(free.size());
    // Taken once: a later trial point writes its own there.
    const bool computed = trial_jacobian && fjac.data() == trial_jacobian && fjac.rows() == m && fjac.cols() == k &&
                          trial_x.size() == x.size() && trial_x == x;
    trial_jacobian = nullptr;
    if (computed) return 0;
    fjac.resize(m, k);
    jacobian_rows(data, params, full_theta(x), free, rows, -1.0, fjac, nullptr, nullptr);
    return 0;
  }

  // m x k storage of the solver's that no one reads now, or null.
  Eigen::MatrixXd* trial_storage() const {
    if (!solver_jacobian) return nullptr;
    const bool allocated = solver_jacobian->rows() == static_cast<Eigen::Index>(rows.count) &&
                           solver_jacobian->cols() == static_cast<Eigen::Index>(free.size());
    // The solver reads its Jacobian only right after df (its column norms
    // and the step's factorisation), never across a call of the functor.
    return allocated ? solver_jacobian : nullptr;
  }

  const ModelData& data;
  const ModelParams& params;
  RowSelection rows;  // the fit samples
  std::vector<int> free;
  // The solver's Jacobian (lm.jacobian()).
  Eigen::MatrixXd* solver_jacobian = nullptr;
  // The Jacobian last computed at a trial point: its storage and the point.
  mutable const double* trial_jacobian = nullptr;
  mutable Eigen::VectorXd trial_x;
};

std::string explain_undetermined(const std::string& name) {
  if (name == "sigma1") {
    return "sigma1 is not determined by these data: bristle damping acts only while the deflection "
           "changes (motion onsets and reversals), and sliding data alone do not constrain it";
  }
  if (name == "sigma0") {
    return "sigma0 is not determined by these data: the presliding displacement Fc/sigma0 is not "
           "resolved by the sampled motion (stiff contact, or too few samples near reversals)";
  }
  if (name == "vs" || name == "Fs" || name == "mu_s") {
    return name + " is not determined by these data: the Stribeck region (low speed) is not "
                  "sampled well enough to separate static friction from its velocity scale";
  }
  return name + " is not determined by these data (standard error larger than its scale)";
}

// The Jacobian's columns: the parameters carried through the simulation as
// dual numbers (derivative j of the duals is output column dual_out[j]) and
// the additive ones, filled from the data (AdditiveColumn).
struct ColumnPlan {
  std::vector<int> dual;
  std::vector<Eigen::Index> dual_out;
  std::vector<std::pair<Eigen::Index, AdditiveColumn>> additive;
  bool reads_drift_basis = false;
  bool through_rest_state = false;  // an additive column enters the pass start from rest (one more dual lane: RestStateLane)
  std::size_t lanes() const { return dual.size() + (through_rest_state ? 1 : 0); }
};

ColumnPlan plan_columns(const ModelData& data, const ModelParams& params, const std::vector<double>& theta,
                        const std::vector<int>& columns) {
  ColumnPlan plan;
  for (std::size_t j = 0; j < columns.size(); ++j) {
    const int k = columns[j];
    const auto out = static_cast<Eigen::Index>(j);
    if (auto c = additive_column(data, params, k, theta[static_cast<std::size_t>(k)])) {
      plan.reads_drift_basis = plan.reads_drift_basis || c->regressor == AdditiveColumn::Regressor::kDriftFunction;
      plan.through_rest_state = plan.through_rest_state || c->through_rest_state;
      plan.additive.emplace_back(out, *c);
    } else {
      plan.dual.push_back(k);
      plan.dual_out.push_back(out);
    }
  }
  return plan;
}

double derivative_of(const double&, std::size_t) { return 0.0; }  // no dual columns
template <class Derivatives>
double derivative_of(const Eigen::AutoDiffScalar<Derivatives>& x, std::size_t j) {
  return x.derivatives()[static_cast<Eigen::Index>(j)];
}

// d model / d theta streamed into out's rows (times sign), the model force
// (optional) into model, the residual at the rows (optional) into residual,
// over samples [begin, end) (simulate_streamed's range), whose first selected
// row is first_row; the dual numbers (T: FixedDual, or double without dual
// columns) live one sample at a time.
template <class T>
void jacobian_range(const ModelData& data, const ModelParams& params, const std::vector<double>& theta,
                    const ColumnPlan& plan, const RowSelection& rows, double sign, Eigen::Ref<Eigen::MatrixXd> out,
                    std::vector<double>* model, Eigen::VectorXd* residual, std::size_t begin, std::size_t end,
                    std::size_t first_row) {
  std::vector<T> dual(theta.size());
  for (std::size_t i = 0; i < theta.size(); ++i) dual[i] = T(theta[i]);
  if constexpr (!std::is_same_v<T, double>) {
    for (std::size_t j = 0; j < plan.dual.size(); ++j) dual[static_cast<std::size_t>(plan.dual[j])].derivatives()[static_cast<Eigen::Index>(j)] = 1.0;
  }
  std::array<double, 16> drift_basis{};
  // d z0 / d theta of each additive column through the current pass's
  // starting state (RestStateLane): minus the column's term summed over the
  // hold's samples that z0 averages (in the simulation's order), over count
  // sigma0; zero where z0 was clamped or before the first pass start.
  std::vector<double> rest_coefficient(plan.additive.size(), 0.0);
  RestStateLane rest;
  if (plan.through_rest_state) {
    rest.lane = static_cast<int>(plan.dual.size());
    rest.on_reset = [&](std::size_t i, std::size_t first, double divisor, bool clamped) {
      std::array<double, 16> basis{};
      for (std::size_t c = 0; c < plan.additive.size(); ++c) {
        const AdditiveColumn& additive = plan.additive[c].second;
        if (!additive.through_rest_state) continue;
        double sum = 0;
        for (std::size_t j = i; !clamped && j-- > first;) {
          if (additive.regressor == AdditiveColumn::Regressor::kDriftFunction) data.drift_basis_at(j, basis.data());
          sum += additive.at(data, j, basis.data(), true);
        }
        rest_coefficient[c] = clamped ? 0.0 : -sum / divisor;
      }
    };
  }
  std::size_t r = first_row;
  const std::vector<double>& measured = *data.fitted_force;
  auto row = [&](std::size_t i, const T& force, const T&, bool evaluated, double rate) {
    if (model) (*model)[i] = value_of(force);
    if (!rows.selects(i, r)) return;
    if (residual) {
      // As ModelFunctor's plain evaluation.
      const double e = measured[i] - value_of(force);
      (*residual)[static_cast<Eigen::Index>(r)] = std::isfinite(e) ? e : 1e30;
    }
    const auto rr = static_cast<Eigen::Index>(r);
    for (std::size_t j = 0; j < plan.dual.size(); ++j) {
      const double v = derivative_of(force, j);
      out(rr, plan.dual_out[j]) = sign * (std::isfinite(v) ? v : 0.0);
    }
    if (plan.reads_drift_basis) data.drift_basis_at(i, drift_basis.data());
    const double per_rest_state = plan.through_rest_state ? derivative_of(force, plan.dual.size()) : 0.0;
    for (std::size_t c = 0; c < plan.additive.size(); ++c) {
      const auto& [column, additive] = plan.additive[c];
      double v = additive.at(data, i, drift_basis.data(), evaluated, rate);
      if (additive.through_rest_state) v += per_rest_state * rest_coefficient[c];
      out(rr, column) = sign * (std::isfinite(v) ? v : 0.0);
    }
    ++r;
  };
  simulate_streamed<T>(data, params, dual, SampleSink<T>(row, model ? nullptr : rows.mask),
                       plan.through_rest_state ? &rest : nullptr, begin, end);
}

// A piece of fewer rows is not simulated on a core of its own: a thread's
// start would cost more than the piece saves.
constexpr std::size_t kMinRowsPerPiece = 10000;

// The selected rows before sample i.
std::size_t rows_before(const RowSelection& rows, std::size_t i) {
  if (rows.mask) {
    return static_cast<std::size_t>(std::count_if(rows.mask->begin(), rows.mask->begin() + static_cast<std::ptrdiff_t>(i),
                                                  [](char c) { return c != 0; }));
  }
  return static_cast<std::size_t>(std::lower_bound(rows.list->begin(), rows.list->end(), i) - rows.list->begin());
}

// The sample of selected row q (0 first).
std::size_t sample_of_row(const RowSelection& rows, std::size_t q, std::size_t n) {
  if (!rows.mask) return (*rows.list)[q];
  std::size_t seen = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if ((*rows.mask)[i] && seen++ == q) return i;
  }
  return n;
}

// The simulation is sequential in time, and a fit ran on one core, idle
// cores beside it where the other fits of its round had ended. Where a
// simulation may start afresh at a pass start (pass_start_near), the record
// is cut at the pass starts nearest equal shares of the rows, one piece per
// core free (cores_free_for_caller), and the pieces are simulated at once:
// each row is the one the whole simulation gives, bit for bit, so nothing
// depends on the cuts (test
// FrictionModel.ASimulationStartedAtAPassStartGivesTheFullSimulationsValues).
// The first sample of each piece, 0 first.
std::vector<std::size_t> piece_starts(const ModelData& data, const ModelParams& params, const RowSelection& rows) {
  const std::size_t n = data.series.size();
  const std::size_t pieces = std::min<std::size_t>(cores_free_for_caller(), rows.count / kMinRowsPerPiece);
  std::vector<std::size_t> starts{0};
  for (std::size_t j = 1; j < pieces; ++j) {
    const std::size_t cut = pass_start_near(data, params, sample_of_row(rows, j * rows.count / pieces, n));
    if (cut > starts.back()) starts.push_back(cut);
  }
  return starts;
}

template <class T>
void jacobian_with(const ModelData& data, const ModelParams& params, const std::vector<double>& theta,
                   const ColumnPlan& plan, const RowSelection& rows, double sign,
                   Eigen::Ref<Eigen::MatrixXd> out, std::vector<double>* model, Eigen::VectorXd* residual) {
  const std::size_t n = data.series.size();
  if (model) model->resize(n);
  const std::vector<std::size_t> starts = piece_starts(data, params, rows);
  parallel_for(starts.size(), static_cast<unsigned>(starts.size()), [&](std::size_t j) {
    const std::size_t begin = starts[j], end = j + 1 < starts.size() ? starts[j + 1] : n;
    jacobian_range<T>(data, params, theta, plan, rows, sign, out, model, residual, begin, end, rows_before(rows, begin));
  });
}

std::atomic<std::uint64_t> model_work{0};

void jacobian_rows(const ModelData& data, const ModelParams& params, const std::vector<double>& theta,
                   const std::vector<int>& columns, const RowSelection& rows, double sign,
                   Eigen::Ref<Eigen::MatrixXd> out, std::vector<double>* model, Eigen::VectorXd* residual) {
  model_work.fetch_add(static_cast<std::uint64_t>(rows.count) * columns.size(), std::memory_order_relaxed);
  const ColumnPlan plan = plan_columns(data, params, theta, columns);
  // The derivative vector's length sets the cost of every operation: the
  // next even width (whole SSE2 registers). Each derivative is computed on
  // its own, element by element, so the padding changes no value.
  const std::size_t k = plan.lanes();
  switch ((k + 1) / 2) {
    case 0: return jacobian_with<double>(data, params, theta, plan, rows, sign, out, model, residual);
    case 1: return jacobian_with<FixedDual<2>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 2: return jacobian_with<FixedDual<4>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 3: return jacobian_with<FixedDual<6>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 4: return jacobian_with<FixedDual<8>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 5: return jacobian_with<FixedDual<10>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 6: return jacobian_with<FixedDual<12>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 7: return jacobian_with<FixedDual<14>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 8: return jacobian_with<FixedDual<16>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 9: return jacobian_with<FixedDual<18>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 10: return jacobian_with<FixedDual<20>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 11: return jacobian_with<FixedDual<22>>(data, params, theta, plan, rows, sign, out, model, residual);
    case 12: return jacobian_with<FixedDual<24>>(data, params, theta, plan, rows, sign, out, model, residual);
    default: break;
  }
  if (k <= 32) return jacobian_with<FixedDual<32>>(data, params, theta, plan, rows, sign, out, model, residual);
  throw std::invalid_argument("model_jacobian: more than 32 free parameters");
}

}  // namespace

void model_jacobian_into(const ModelData& data, const ModelParams& params, const std::vector<double>& theta,
                         const std::vector<int>& columns, const std::vector<std::size_t>& rows, double sign,
                         Eigen::Ref<Eigen::MatrixXd> out, std::vector<double>* model) {
  if (!std::is_sorted(rows.begin(), rows.end()) || std::adjacent_find(rows.begin(), rows.end()) != rows.end()) {
    throw std::invalid_argument("model_jacobian: rows must be in time order, each once");
  }
  if (out.rows() != static_cast<Eigen::Index>(rows.size()) || out.cols() != static_cast<Eigen::Index>(columns.size())) {
    throw std::invalid_argument("model_jacobian: output of the wrong size");
  }
  jacobian_rows(data, params, theta, columns, RowSelection{&rows, nullptr, rows.size()}, sign, out, model, nullptr);
}

Eigen::MatrixXd model_jacobian(const ModelData& data, const ModelParams& params, const std::vector<double>& theta,
                               const std::vector<int>& columns, const std::vector<std::size_t>& rows,
                               std::vector<double>* model) {
  Eigen::MatrixXd jac(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(columns.size()));
  model_jacobian_into(data, params, theta, columns, rows, 1.0, jac, model);
  return jac;
}

std::uint64_t model_work_done() { return model_work.load(std::memory_order_relaxed); }

double effective_sample_count(const double* r, std::size_t n) {
  if (n < 3) return static_cast<double>(n);
  double num = 0, den = 0;
  for (std::size_t i = 1; i < n; ++i) num += r[i] * r[i - 1];
  for (std::size_t i = 0; i < n; ++i) den += r[i] * r[i];
  const double rho = den > 0 ? std::clamp(num / den, 0.0, 0.9999) : 0.0;
  return std::clamp(static_cast<double>(n) * (1 - rho) / (1 + rho), 1.0, static_cast<double>(n));
}

double effective_sample_count(const std::vector<double>& r) { return effective_sample_count(r.data(), r.size()); }

double aicc(double rss, std::size_t n, double n_eff, std::size_t k) {
  const double kk = static_cast<double>(k);
  if (n == 0 || rss <= 0 || n_eff <= kk + 1) return std::numeric_limits<double>::infinity();
  return n_eff * std::log(rss / static_cast<double>(n)) + 2 * kk + 2 * kk * (kk + 1) / (n_eff - kk - 1);
}

double residual_sum_of_squares(const ModelData& data, const ModelParams& params, const std::vector<char>& in_fit) {
  double rss = 0;
  const std::vector<double>& measured = *data.fitted_force;
  auto add = [&](std::size_t i, const double& force, const double&) {
    if (!in_fit[i]) return;
    const double e = measured[i] - force;
    rss += std::isfinite(e) ? e * e : 1e60;
  };
  simulate_streamed<double>(data, params, params.theta, SampleSink<double>(add, &in_fit));
  return rss;
}

FitResult fit_model(const ModelData& data, const ModelParams& initial, const std::vector<char>& in_fit,
                    const FitOptions& options) {
  FitResult result;
  result.params = initial;
  std::vector<int> free;
  for (std::size_t k = 0; k < initial.specs.size(); ++k) {
    if (!initial.specs[k].fixed) free.push_back(static_cast<int>(k));
  }
  // The fit samples are selected by the mask itself (an index per sample
  // and fit would be the largest array after the Jacobian).
  const auto fit_samples = static_cast<std::size_t>(std::count_if(in_fit.begin(), in_fit.end(), [](char c) { return c != 0; }));
  result.n = fit_samples;
  result.k = free.size();
  if (free.empty() || fit_samples <= free.size()) {
    result.rss = residual_sum_of_squares(data, initial, in_fit);
    result.warnings.push_back("too few fit samples for the model's parameters");
    return result;
  }

  ModelFunctor functor(data, initial, in_fit, fit_samples, free);
  Eigen::VectorXd x(static_cast<Eigen::Index>(free.size()));
  for (std::size_t j = 0; j < free.size(); ++j) {
    x[static_cast<Eigen::Index>(j)] = initial.theta[static_cast<std::size_t>(free[j])] + ModelFunctor::kShift;
  }
  Eigen::LevenbergMarquardt<ModelFunctor> lm(functor);
  functor.solver_jacobian = &lm.jacobian();
  const ChunkedQR::ResidualScope residual_scope(lm.jacobian(), lm.fvec());
  lm.setMaxfev(options.max_iterations * 10);
  lm.setFtol(options.tolerance);
  lm.setXtol(options.tolerance);
  // The first trust region: a step of about one in the normalised parameters
  // (a factor e for log parameters); MINPACK's default of 100 lets the
  // first step throw an ill-determined scale e^100 away.
  lm.setFactor(1.0);
  // The trust region lives in the normalised parameters themselves (unit
  // scaling): Marquardt's scaling by the Jacobian's column norms would let a
  // parameter the data hardly feel take an enormous step.
  lm.setExternalScaling(true);
  lm.diag() = Eigen::VectorXd::Ones(static_cast<Eigen::Index>(free.size()));
  // Eigen's own tests stop on tiny relative changes; in the long shallow
  // valleys of undetermined parameters that takes hundreds of iterations for
  // cost changes no data could tell apart. Stop as well once the cost has
  // fallen by less than kStallLogLikelihood in log-likelihood units
  // (n_eff/2 * relative RSS change) over the last kStallWindow iterations.
  constexpr int kStallWindow = 4;
  constexpr double kStallLogLikelihood = 0.05;
  auto status = lm.minimizeInit(x);
  std::vector<double> costs;
  bool stalled = false;
  const bool started = status != Eigen::LevenbergMarquardtSpace::ImproperInputParameters;
  if (started) {
    do {
      status = lm.minimizeOneStep(x);
      const double cost = lm.fnorm() * lm.fnorm();
      costs.push_back(cost);
      if (costs.size() > kStallWindow) {
        const double before = costs[costs.size() - 1 - kStallWindow];
        const double n_eff = effective_sample_count(lm.fvec().data(), static_cast<std::size_t>(lm.fvec().size()));
        const double gain = 0.5 * n_eff * (before - cost) / cost;
        stalled = gain < kStallLogLikelihood;
      }
      if (static_cast<int>(lm.njev()) >= options.max_iterations) break;
    } while (status == Eigen::LevenbergMarquardtSpace::Running && !stalled);
  }
  result.iterations = static_cast<int>(lm.njev());
  result.converged = status == Eigen::LevenbergMarquardtSpace::RelativeReductionTooSmall ||
                     status == Eigen::LevenbergMarquardtSpace::RelativeErrorTooSmall ||
                     status == Eigen::LevenbergMarquardtSpace::RelativeErrorAndReductionTooSmall ||
                     status == Eigen::LevenbergMarquardtSpace::FtolTooSmall ||
                     status == Eigen::LevenbergMarquardtSpace::XtolTooSmall || stalled;
  if (!result.converged) result.warnings.push_back("the fit stopped before converging (Levenberg-Marquardt status " + std::to_string(static_cast<int>(status)) + ")");
  result.params.theta = functor.full_theta(x);

  // Residual, effective sample count, AICc.
  // (The solver's own vectors and Jacobian are reused: it is done.) The
  // solver keeps its residual at x: evaluated again only when it never
  // started.
  Eigen::VectorXd& fvec = lm.fvec();
  if (!started) functor(x, fvec);
  result.rss = fvec.squaredNorm();
  result.n_effective = effective_sample_count(fvec.data(), static_cast<std::size_t>(fvec.size()));
  result.aicc = aicc(result.rss, result.n, result.n_effective, result.k);

  // Covariance of theta from the Jacobian at the solution.
  Eigen::MatrixXd& jac = lm.jacobian();
  functor.df(x, jac);
  const Eigen::MatrixXd jtj = jac.transpose() * jac;
  const double dof = static_cast<double>(fit_samples - free.size());
  const double s2 = result.rss / dof * (static_cast<double>(result.n) / result.n_effective);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(jtj);
  const Eigen::VectorXd ev = eig.eigenvalues();
  const double ev_max = ev.maxCoeff();
  Eigen::MatrixXd inverse = Eigen::MatrixXd::Zero(jtj.rows(), jtj.cols());
  for (Eigen::Index j = 0; j < ev.size(); ++j) {
    if (ev[j] > 1e-13 * ev_max) inverse += eig.eigenvectors().col(j) * eig.eigenvectors().col(j).transpose() / ev[j];
  }
  Eigen::MatrixXd cov = s2 * inverse;
  // Cluster-robust (sandwich) covariance over the record's blocks (passes,
  // or time chunks): the residual of a pass is one correlated lump (a
  // motion-estimate error, a model mismatch), which the lag-1 inflation
  // above does not see; with independent passes, sum over blocks of
  // (J_b^T r_b)(J_b^T r_b)^T estimates the score's variance whatever the
  // correlation inside a block (small-sample factor G/(G-1)). Each
  // parameter keeps the larger of the two standard errors.
  {
    std::map<int, Eigen::VectorXd> score;
    for (std::size_t i = 0, r = 0; i < in_fit.size(); ++i) {
      if (!in_fit[i]) continue;
      const int block = data.motion.block_of.empty() ? 0 : data.motion.block_of[i];
      auto it = score.find(block);
      if (it == score.end()) it = score.emplace(block, Eigen::VectorXd::Zero(jac.cols())).first;
      it->second += jac.row(static_cast<Eigen::Index>(r)).transpose() * fvec[static_cast<Eigen::Index>(r)];
      ++r;
    }
    const double groups = static_cast<double>(score.size());
    if (groups >= 4) {
      Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(jac.cols(), jac.cols());
      for (const auto& [block, g] : score) meat += g * g.transpose();
      meat *= groups / (groups - 1);
      const Eigen::MatrixXd sandwich = inverse * meat * inverse;
      for (Eigen::Index j = 0; j < cov.rows(); ++j) {
        if (cov(j, j) > 0 && sandwich(j, j) > cov(j, j)) {
          const double ratio = std::sqrt(sandwich(j, j) / std::max(cov(j, j), 1e-300));
          cov.row(j) *= ratio;
          cov.col(j) *= ratio;
        }
      }
    }
  }
  // Near-collinear parameter pairs (a null direction of J^T J). The
  // pseudo-inverse above leaves the null directions out, so a parameter
  // along one would get a standard error of the directions that remain
  // (1e-24 for a bristle damping driven to 1e-10): it has none.
  std::vector<char> along_null(static_cast<std::size_t>(ev.size()), 0);
  if (ev.size() > 0 && ev.minCoeff() <= 1e-13 * ev_max) {
    std::string names;
    for (Eigen::Index c = 0; c < ev.size(); ++c) {
      if (ev[c] > 1e-13 * ev_max) continue;
      for (Eigen::Index j = 0; j < ev.size(); ++j) {
        if (std::fabs(eig.eigenvectors()(j, c)) > 0.3) along_null[static_cast<std::size_t>(j)] = 1;
      }
    }
    for (Eigen::Index j = 0; j < ev.size(); ++j) {
      if (along_null[static_cast<std::size_t>(j)]) names += (names.empty() ? "" : ", ") + initial.specs[static_cast<std::size_t>(free[static_cast<std::size_t>(j)])].name;
    }
    result.warnings.push_back("parameters not separately determined (collinear in these data): " + names);
  }

  std::size_t j = 0;
  Eigen::VectorXd value_per_theta = Eigen::VectorXd::Zero(cov.rows());
  result.covariance_row.assign(initial.specs.size(), -1);
  for (std::size_t k = 0; k < initial.specs.size(); ++k) {
    const ParamSpec& spec = initial.specs[k];
    ParamEstimate e{spec.name, spec.unit, param_value(spec, result.params.theta[k]), 0.0, spec.fixed, true, spec.effect};
    if (!spec.fixed) {
      const auto jj = static_cast<Eigen::Index>(j++);
      result.covariance_row[k] = static_cast<int>(jj);
      const double se_theta = std::sqrt(std::max(cov(jj, jj), 0.0));
      const bool singular = along_null[static_cast<std::size_t>(jj)] || (ev.minCoeff() <= 1e-13 * ev_max && cov(jj, jj) == 0.0);
      double derivative = 0;  // d value / d theta
      switch (spec.transform) {
        case Transform::kLog: derivative = e.value; break;
        case Transform::kLinear: derivative = spec.scale; break;
        case Transform::kLogit: derivative = e.value * (1 - e.value); break;
      }
      e.std_error = singular ? std::numeric_limits<double>::quiet_NaN() : std::fabs(derivative) * se_theta;
      value_per_theta[jj] = derivative;
      // Normalised-scale rule; logit fractions near 0 or 1 use the value's own scale.
      double normalised = se_theta;
      if (spec.transform == Transform::kLinear) normalised = spec.scale > 0 ? e.std_error / spec.scale : se_theta;
      if (spec.transform == Transform::kLinear && std::fabs(e.value) > spec.scale) normalised = e.std_error / std::fabs(e.value);
      e.determined = !singular && normalised <= 1.0;
      if (!e.determined) result.warnings.push_back(explain_undetermined(spec.name));
    }
    result.estimates.push_back(e);
  }
  result.covariance = value_per_theta.asDiagonal() * cov * value_per_theta.asDiagonal();
  return result;
}

std::vector<ParamEstimate> parameters_of(const FitResult& fit, Effect effect) {
  std::vector<ParamEstimate> out;
  for (const auto& e : fit.estimates) {
    if (e.effect == effect) out.push_back(e);
  }
  return out;
}

}  // namespace tribo::analysis
