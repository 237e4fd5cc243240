#include "calibration/fit/fit_diagnostics.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "common/check.h"
#include "common/input_error.h"

namespace parallax {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Pseudo-inverse of a symmetric PSD block, dropping directions that conditioningOf would call
// rank deficient (in the unit-diagonal scaling), so one undetermined module does not poison
// the Schur complement with a huge, meaningless inverse.
Eigen::MatrixXd pseudoInverse(const Eigen::MatrixXd& h, double cutoff,
                              std::vector<bool>* nullMask) {
  const int n = static_cast<int>(h.rows());
  Eigen::VectorXd scale(n);
  for (int j = 0; j < n; ++j) scale[j] = h(j, j) > 0.0 ? 1.0 / std::sqrt(h(j, j)) : 0.0;
  const Eigen::MatrixXd scaled = scale.asDiagonal() * h * scale.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const double top = lambda.size() ? lambda.maxCoeff() : 0.0;
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(n);
  if (nullMask) nullMask->assign(static_cast<size_t>(n), false);
  for (int i = 0; i < n; ++i) {
    if (top > 0.0 && lambda[i] > cutoff * top) {
      inv[i] = 1.0 / lambda[i];
    } else if (nullMask) {
      // Every parameter with weight in a dropped direction is undetermined.
      for (int j = 0; j < n; ++j) {
        if (std::abs(eig.eigenvectors()(j, i)) > 0.1) (*nullMask)[static_cast<size_t>(j)] = true;
      }
    }
  }
  for (int j = 0; j < n; ++j) {
    if (scale[j] == 0.0 && nullMask) (*nullMask)[static_cast<size_t>(j)] = true;
  }
  return scale.asDiagonal() * eig.eigenvectors() * inv.asDiagonal() *
         eig.eigenvectors().transpose() * scale.asDiagonal();
}

}  // namespace

void ConditioningOptions::validate() const {
  if (!(rankDeficientBelow > 0.0 && rankDeficientBelow <= poorlyConditionedBelow &&
        poorlyConditionedBelow < 1.0)) {
    throw InputError({"", "conditioning", 0},
                     "need 0 < rank_deficient_below <= poorly_conditioned_below < 1");
  }
}

const char* conditioningName(Conditioning c) {
  switch (c) {
    case Conditioning::kGood:
      return "good";
    case Conditioning::kPoor:
      return "poorly conditioned";
    case Conditioning::kRankDeficient:
      return "rank deficient";
    case Conditioning::kUndetermined:
      return "undetermined by the data";
  }
  return "?";
}

InformationBlocks informationFromJacobian(int numRows, int numCols, const std::vector<int>& rows,
                                          const std::vector<int>& cols,
                                          const std::vector<double>& values, int moduleCount,
                                          int moduleSize, int sharedSize,
                                          const std::vector<double>* rowWeights) {
  PARALLAX_CHECK_OP(numCols, ==, moduleCount * moduleSize + sharedSize);
  PARALLAX_CHECK_OP(static_cast<int>(rows.size()), ==, numRows + 1);
  InformationBlocks info;
  info.moduleModule.assign(static_cast<size_t>(moduleCount),
                           Eigen::MatrixXd::Zero(moduleSize, moduleSize));
  info.moduleShared.assign(static_cast<size_t>(moduleCount),
                           Eigen::MatrixXd::Zero(moduleSize, sharedSize));
  info.sharedShared = Eigen::MatrixXd::Zero(sharedSize, sharedSize);
  const int sharedStart = moduleCount * moduleSize;
  // Each row touches at most one module (the fit's structure); accumulate its outer product
  // into the blocks it touches.
  std::vector<std::pair<int, double>> moduleEntries, sharedEntries;
  for (int r = 0; r < numRows; ++r) {
    moduleEntries.clear();
    sharedEntries.clear();
    int module = -1;
    for (int k = rows[static_cast<size_t>(r)]; k < rows[static_cast<size_t>(r) + 1]; ++k) {
      const int c = cols[static_cast<size_t>(k)];
      const double v = values[static_cast<size_t>(k)];
      if (v == 0.0) continue;
      if (c >= sharedStart) {
        sharedEntries.push_back({c - sharedStart, v});
      } else {
        const int m = c / moduleSize;
        PARALLAX_CHECK(module < 0 || module == m);
        module = m;
        moduleEntries.push_back({c - m * moduleSize, v});
      }
    }
    const double w = rowWeights ? (*rowWeights)[static_cast<size_t>(r)] : 1.0;
    for (const auto& [i, vi] : sharedEntries) {
      for (const auto& [j, vj] : sharedEntries) info.sharedShared(i, j) += w * vi * vj;
    }
    if (module < 0) continue;
    Eigen::MatrixXd& hmm = info.moduleModule[static_cast<size_t>(module)];
    Eigen::MatrixXd& hms = info.moduleShared[static_cast<size_t>(module)];
    for (const auto& [i, vi] : moduleEntries) {
      for (const auto& [j, vj] : moduleEntries) hmm(i, j) += w * vi * vj;
      for (const auto& [j, vj] : sharedEntries) hms(i, j) += w * vi * vj;
    }
  }
  return info;
}

void subtractCommonPart(const Eigen::VectorXd& moduleSum, const Eigen::VectorXd& sharedSum,
                        int module, double coefficient, InformationBlocks* info) {
  info->sharedShared.noalias() -= coefficient * sharedSum * sharedSum.transpose();
  if (module < 0) return;
  const auto m = static_cast<size_t>(module);
  info->moduleModule[m].noalias() -= coefficient * moduleSum * moduleSum.transpose();
  info->moduleShared[m].noalias() -= coefficient * moduleSum * sharedSum.transpose();
}

BlockConditioning conditioningOf(const Eigen::MatrixXd& block, const ConditioningOptions& options) {
  BlockConditioning out;
  const int n = static_cast<int>(block.rows());
  if (n == 0) return out;
  // A parameter no residual depends on is undetermined outright.
  std::vector<int> unseen;
  for (int j = 0; j < n; ++j) {
    if (!(block(j, j) > 0.0)) unseen.push_back(j);
  }
  if (!unseen.empty()) {
    out.state = Conditioning::kRankDeficient;
    out.reciprocalCondition = 0.0;
    out.nullDirection = unseen;
    return out;
  }
  Eigen::VectorXd scale(n);
  for (int j = 0; j < n; ++j) scale[j] = 1.0 / std::sqrt(block(j, j));
  const Eigen::MatrixXd scaled = scale.asDiagonal() * block * scale.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  const double top = eig.eigenvalues().maxCoeff();
  const double bottom = std::max(0.0, eig.eigenvalues().minCoeff());
  out.reciprocalCondition = top > 0.0 ? bottom / top : 0.0;
  if (out.reciprocalCondition < options.rankDeficientBelow) {
    out.state = Conditioning::kRankDeficient;
  } else if (out.reciprocalCondition < options.poorlyConditionedBelow) {
    out.state = Conditioning::kPoor;
  }
  if (out.state != Conditioning::kGood) {
    const Eigen::VectorXd v = eig.eigenvectors().col(0);  // eigenvalues ascend
    std::vector<int> order(static_cast<size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return std::abs(v[a]) > std::abs(v[b]); });
    for (int j : order) {
      if (std::abs(v[j]) >= options.nameComponentsAbove) out.nullDirection.push_back(j);
    }
  }
  return out;
}

Diagnostics diagnose(const InformationBlocks& info, const ConditioningOptions& options) {
  options.validate();
  Diagnostics out;
  const size_t moduleCount = info.moduleModule.size();
  const int sharedSize = static_cast<int>(info.sharedShared.rows());

  // Shared block after eliminating every module: S = H_ss − Σ H_si H_ii⁺ H_is.
  std::vector<Eigen::MatrixXd> inverses(moduleCount);
  std::vector<std::vector<bool>> nullMasks(moduleCount);
  Eigen::MatrixXd schur = info.sharedShared;
  for (size_t m = 0; m < moduleCount; ++m) {
    out.modules.push_back(conditioningOf(info.moduleModule[m], options));
    inverses[m] = pseudoInverse(info.moduleModule[m], options.rankDeficientBelow, &nullMasks[m]);
    schur -= info.moduleShared[m].transpose() * inverses[m] * info.moduleShared[m];
  }
  schur = 0.5 * (schur + schur.transpose());
  out.shared = conditioningOf(schur, options);
  std::vector<bool> sharedNull;
  const Eigen::MatrixXd sharedCov = pseudoInverse(schur, options.rankDeficientBelow, &sharedNull);
  out.sharedStdDev = sharedCov.diagonal().cwiseMax(0.0).cwiseSqrt();
  out.sharedCovariance = sharedCov;
  for (int j = 0; j < sharedSize; ++j) {
    if (sharedNull[static_cast<size_t>(j)]) out.sharedStdDev[j] = kInf;
  }

  for (size_t m = 0; m < moduleCount; ++m) {
    const Eigen::MatrixXd coupling = inverses[m] * info.moduleShared[m];
    const Eigen::MatrixXd cov = inverses[m] + coupling * sharedCov * coupling.transpose();
    Eigen::VectorXd sd = cov.diagonal().cwiseMax(0.0).cwiseSqrt();
    for (int j = 0; j < sd.size(); ++j) {
      if (nullMasks[m][static_cast<size_t>(j)]) sd[j] = kInf;
    }
    out.moduleStdDev.push_back(sd);
    out.moduleCovariance.push_back(cov);
    out.moduleSharedCovariance.push_back(-coupling * sharedCov);
  }
  return out;
}

namespace {

// A cluster that alone decides a direction (leverage 1) leaves no residual to tell how far off it
// is; the gate refuses a module seen from one station for that. Capping keeps the rest finite:
// such a direction's score is widened tenfold at most.
constexpr double kMaxLeverage = 0.99;

// CR2's score (widenToClusterRobust). With J̃_c = Ω_c^(−½) J_c = Q S^½ Uᵀ (M_c = J̃ᵀJ̃ = U S Uᵀ)
// and C the covariance over the cluster's parameters, H_cc = Q K Qᵀ, K = S^½ Uᵀ C U S^½ = V Λ Vᵀ,
// so J̃ᵀ (I − H_cc)^(−½) ẽ = U S^½ (I + V D Vᵀ) S^(−½) Uᵀ s, D = (1 − Λ)^(−½) − 1.
Eigen::VectorXd leverageCorrected(const Eigen::VectorXd& score, const Eigen::MatrixXd& information,
                                  const Eigen::MatrixXd& covariance) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> m(information);
  const Eigen::VectorXd& s = m.eigenvalues();
  const double top = s.size() ? s.maxCoeff() : 0.0;
  if (!(top > 0.0) || !covariance.allFinite()) return score;
  std::vector<Eigen::Index> kept;
  for (Eigen::Index i = 0; i < s.size(); ++i) {
    if (s[i] > 1e-12 * top) kept.push_back(i);
  }
  const auto rank = static_cast<Eigen::Index>(kept.size());
  Eigen::MatrixXd u(information.rows(), rank);
  Eigen::VectorXd root(rank);
  for (Eigen::Index j = 0; j < rank; ++j) {
    u.col(j) = m.eigenvectors().col(kept[static_cast<size_t>(j)]);
    root[j] = std::sqrt(s[kept[static_cast<size_t>(j)]]);
  }
  const Eigen::MatrixXd w = u * root.asDiagonal();
  const Eigen::MatrixXd k = w.transpose() * covariance * w;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> leverage(0.5 * (k + k.transpose()));
  Eigen::VectorXd d(rank);
  for (Eigen::Index j = 0; j < rank; ++j) {
    const double lambda = std::clamp(leverage.eigenvalues()[j], 0.0, kMaxLeverage);
    d[j] = 1.0 / std::sqrt(1.0 - lambda) - 1.0;
  }
  const Eigen::VectorXd inSpan = u.transpose() * score;
  Eigen::VectorXd q = inSpan.cwiseQuotient(root);
  const Eigen::MatrixXd& v = leverage.eigenvectors();
  q += v * d.asDiagonal() * (v.transpose() * q);
  return w * q + (score - u * inSpan);
}

// max(1, tr(a⁻¹ b) / n) for a positive definite a; 1 otherwise.
double widening(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  const Eigen::LLT<Eigen::MatrixXd> llt(a);
  if (a.rows() == 0 || llt.info() != Eigen::Success || !b.allFinite()) return 1.0;
  return std::max(1.0, llt.solve(b).trace() / static_cast<double>(a.rows()));
}

}  // namespace

void widenToClusterRobust(const InformationBlocks& info, const std::vector<ClusterScore>& scores,
                          const ConditioningOptions& options, Diagnostics* d) {
  const size_t moduleCount = info.moduleModule.size();
  const Eigen::Index sharedSize = info.sharedShared.rows();
  if (scores.size() < 2) return;
  // H⁻¹ s by the Schur complement, for a score touching module m and the shared block:
  //   a = H_mm⁻¹ s_m,  x_s = Σ_ss (s_s − H_msᵀ a),  x_i = δ_im a − G_i x_s, G_i = H_ii⁻¹ H_is.
  // Summed over the clusters, with X = Σ x_s x_sᵀ, P_m = Σ_{c in m} a aᵀ, Q_m = Σ_{c in m} a x_sᵀ:
  //   Σ_sw,ii = P_i − Q_i G_iᵀ − G_i Q_iᵀ + G_i X G_iᵀ,  Σ_sw,ss = X.
  std::vector<Eigen::MatrixXd> inverses(moduleCount), couplings(moduleCount);
  std::vector<Eigen::MatrixXd> p(moduleCount), q(moduleCount);
  for (size_t m = 0; m < moduleCount; ++m) {
    inverses[m] = pseudoInverse(info.moduleModule[m], options.rankDeficientBelow, nullptr);
    couplings[m] = inverses[m] * info.moduleShared[m];
    const Eigen::Index n = info.moduleModule[m].rows();
    p[m] = Eigen::MatrixXd::Zero(n, n);
    q[m] = Eigen::MatrixXd::Zero(n, sharedSize);
  }
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(sharedSize, sharedSize);
  const double smallSample = static_cast<double>(scores.size()) / (scores.size() - 1.0);
  const bool sharedDetermined = d->sharedStdDev.allFinite();
  for (const ClusterScore& c : scores) {
    const auto m = static_cast<size_t>(c.module);
    Eigen::VectorXd modulePart = c.modulePart;
    Eigen::VectorXd shared = c.sharedPart;
    // CR2 needs the covariance over the cluster's parameters; an undetermined one has none, and
    // its score is taken raw, with the small-sample factor n / (n − 1) instead.
    double correction = smallSample;
    const bool moduleDetermined = c.module < 0 || d->moduleStdDev[m].allFinite();
    if (c.information.size() > 0 && sharedDetermined && moduleDetermined) {
      const Eigen::Index n = c.modulePart.size();
      Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(n + sharedSize, n + sharedSize);
      covariance.bottomRightCorner(sharedSize, sharedSize) = d->sharedCovariance;
      if (c.module >= 0) {
        covariance.topLeftCorner(n, n) = d->moduleCovariance[m];
        covariance.topRightCorner(n, sharedSize) = d->moduleSharedCovariance[m];
        covariance.bottomLeftCorner(sharedSize, n) = d->moduleSharedCovariance[m].transpose();
      }
      Eigen::VectorXd score(n + sharedSize);
      score << c.modulePart, c.sharedPart;
      const Eigen::VectorXd corrected = leverageCorrected(score, c.information, covariance);
      modulePart = corrected.head(n);
      shared = corrected.tail(sharedSize);
      correction = 1.0;
    }
    Eigen::VectorXd a;
    if (c.module >= 0) {
      a = inverses[m] * modulePart;
      shared -= info.moduleShared[m].transpose() * a;
    }
    const Eigen::VectorXd xs = d->sharedCovariance * shared;
    x.noalias() += correction * xs * xs.transpose();
    if (c.module >= 0) {
      p[m].noalias() += correction * a * a.transpose();
      q[m].noalias() += correction * a * xs.transpose();
    }
  }
  const auto widenStdDev = [](const Eigen::MatrixXd& cov, Eigen::VectorXd* sd) {
    for (Eigen::Index j = 0; j < sd->size(); ++j) {
      if (std::isfinite((*sd)[j])) (*sd)[j] = std::sqrt(std::max(0.0, cov(j, j)));
    }
  };
  const double fs = d->sharedStdDev.allFinite() ? widening(d->sharedCovariance, x) : 1.0;
  d->sharedCovariance *= fs;
  widenStdDev(d->sharedCovariance, &d->sharedStdDev);
  for (size_t m = 0; m < moduleCount; ++m) {
    if (!d->moduleStdDev[m].allFinite()) continue;
    const Eigen::MatrixXd& g = couplings[m];
    const Eigen::MatrixXd gq = g * q[m].transpose();
    const Eigen::MatrixXd sandwich = p[m] - gq - gq.transpose() + g * x * g.transpose();
    const double f = widening(d->moduleCovariance[m], sandwich);
    d->moduleCovariance[m] *= f;
    d->moduleSharedCovariance[m] *= std::sqrt(f * fs);  // the same correlation
    widenStdDev(d->moduleCovariance[m], &d->moduleStdDev[m]);
  }
}

Eigen::MatrixXd solveInformation(const InformationBlocks& info, const Diagnostics& d,
                                 const ConditioningOptions& options,
                                 const Eigen::MatrixXd& scores) {
  const size_t moduleCount = info.moduleModule.size();
  const Eigen::Index sharedSize = info.sharedShared.rows();
  const Eigen::Index moduleSize = moduleCount ? info.moduleModule[0].rows() : 0;
  const Eigen::Index sharedStart = static_cast<Eigen::Index>(moduleCount) * moduleSize;
  PARALLAX_CHECK_OP(scores.rows(), ==, sharedStart + sharedSize);
  // x_s = Σ_ss (g_s − Σ_i H_isᵀ H_ii⁻¹ g_i),  x_i = H_ii⁻¹ (g_i − H_is x_s).
  std::vector<Eigen::MatrixXd> inverses(moduleCount);
  Eigen::MatrixXd reduced = scores.bottomRows(sharedSize);
  for (size_t m = 0; m < moduleCount; ++m) {
    inverses[m] = pseudoInverse(info.moduleModule[m], options.rankDeficientBelow, nullptr);
    reduced.noalias() -= info.moduleShared[m].transpose() * inverses[m] *
                         scores.middleRows(static_cast<Eigen::Index>(m) * moduleSize, moduleSize);
  }
  Eigen::MatrixXd x(scores.rows(), scores.cols());
  x.bottomRows(sharedSize) = d.sharedCovariance * reduced;
  for (size_t m = 0; m < moduleCount; ++m) {
    const Eigen::Index start = static_cast<Eigen::Index>(m) * moduleSize;
    x.middleRows(start, moduleSize) =
        inverses[m] *
        (scores.middleRows(start, moduleSize) - info.moduleShared[m] * x.bottomRows(sharedSize));
  }
  return x;
}

void addCarriedCovariance(const Eigen::MatrixXd& x, const Eigen::MatrixXd& heldCovariance,
                          Diagnostics* d) {
  const size_t moduleCount = d->moduleCovariance.size();
  const Eigen::Index sharedSize = d->sharedCovariance.rows();
  const Eigen::Index moduleSize = moduleCount ? d->moduleCovariance[0].rows() : 0;
  PARALLAX_CHECK_OP(x.rows(), ==, static_cast<Eigen::Index>(moduleCount) * moduleSize + sharedSize);
  PARALLAX_CHECK_OP(x.cols(), ==, heldCovariance.rows());
  const Eigen::MatrixXd xs = x.bottomRows(sharedSize);
  const Eigen::MatrixXd xsSigma = xs * heldCovariance;
  const auto addToStdDev = [](const Eigen::MatrixXd& cov, Eigen::VectorXd* sd) {
    for (Eigen::Index j = 0; j < sd->size(); ++j) {
      if (std::isfinite((*sd)[j])) (*sd)[j] = std::sqrt(std::max(0.0, cov(j, j)));
    }
  };
  if (d->sharedStdDev.allFinite()) {
    d->sharedCovariance.noalias() += xsSigma * xs.transpose();
    addToStdDev(d->sharedCovariance, &d->sharedStdDev);
  }
  for (size_t m = 0; m < moduleCount; ++m) {
    if (!d->moduleStdDev[m].allFinite()) continue;
    const Eigen::MatrixXd xm = x.middleRows(static_cast<Eigen::Index>(m) * moduleSize, moduleSize);
    d->moduleCovariance[m].noalias() += xm * heldCovariance * xm.transpose();
    d->moduleSharedCovariance[m].noalias() += xm * xsSigma.transpose();
    addToStdDev(d->moduleCovariance[m], &d->moduleStdDev[m]);
  }
}

}  // namespace parallax
