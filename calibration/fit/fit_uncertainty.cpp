#include "calibration/fit/fit_uncertainty.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <unordered_map>

#include "calibration/fit/fit_diagnostics.h"

namespace parallax::fit {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;
// Ceres' quaternion tangent δ turns by 2|δ| (Plus multiplies by [cos|δ|, sin|δ| δ/|δ|]): a
// rotation's σ in degrees is twice its tangent's.
constexpr double kTangentToRotationDeg = 2.0 * kRadToDeg;

// Row r of the Jacobian over one cluster's parameters [its module | shared]: its nonzeros as
// (index, value) into `entries`, and the module it touches into `module` (left as it is when
// it touches none).
void clusterRowEntries(const ceres::CRSMatrix& jacobian, size_t r, int sharedStart, int* module,
                       std::vector<std::pair<int, double>>* entries) {
  entries->clear();
  for (int k = jacobian.rows[r]; k < jacobian.rows[r + 1]; ++k) {
    const int col = jacobian.cols[static_cast<size_t>(k)];
    if (col < sharedStart) *module = col / kModuleTangentSize;
    entries->emplace_back(
        col < sharedStart ? col % kModuleTangentSize : kModuleTangentSize + col - sharedStart,
        jacobian.values[static_cast<size_t>(k)]);
  }
}

// The sum of a group's rows over its cluster's parameters [module | shared], and its module.
Eigen::VectorXd groupRowSum(const ceres::CRSMatrix& jacobian, const std::vector<int>& members,
                            int sharedStart, int sharedSize, int* module) {
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(kModuleTangentSize + sharedSize);
  std::vector<std::pair<int, double>> entries;
  for (int r : members) {
    clusterRowEntries(jacobian, static_cast<size_t>(r), sharedStart, module, &entries);
    for (const auto& [i, v] : entries) sum[i] += v;
  }
  return sum;
}

// What the σ-normalised rows of a group (FitProblem::groupOf, per axis) share: each group's
// rows as w I + b 11ᵀ, with w and b measured from the residuals at the solution per kind of row
// (correspondence u, v; stripe): w the pooled spread within the groups (taken as at least 1:
// the σ that scales the rows), b what the groups' means spread beyond w / n. Independent rows
// give b ≈ 0, and the plain JᵀJ. Ω⁻¹ of a group is (1/w) [I − b / (w + n b) 11ᵀ]: a weight 1/w
// a row and `coefficient` = b / (w (w + n b)) on its sums.
struct SharedErrorModel {
  struct Group {
    int kind = 0, rows = 0;
    double sum = 0.0, coefficient = 0.0;
    std::vector<int> members;
  };
  std::vector<Group> groups;
  std::vector<double> weights;  // per row
};

SharedErrorModel sharedErrorModel(const FitProblem& built, const std::vector<double>& residuals,
                                  FitResult* result) {
  constexpr int kKinds = 3;  // correspondence u, correspondence v, stripe
  SharedErrorModel model;
  std::vector<SharedErrorModel::Group>& groups = model.groups;
  std::vector<int> groupOfRow(residuals.size(), -1);
  {
    std::unordered_map<std::int64_t, int> index;
    int row = 0;
    for (size_t b = 0; b < built.residualBlocks.size(); ++b) {
      const int rows =
          built.problem->GetCostFunctionForResidualBlock(built.residualBlocks[b])->num_residuals();
      for (int axis = 0; axis < rows; ++axis, ++row) {
        const std::int64_t g = built.groupOf[b];
        if (g < 0) continue;
        const auto [it, fresh] = index.try_emplace(g * 2 + axis, static_cast<int>(groups.size()));
        if (fresh) {
          SharedErrorModel::Group group;
          group.kind = (g & 1) ? 2 : axis;
          groups.push_back(group);
        }
        SharedErrorModel::Group& group = groups[static_cast<size_t>(it->second)];
        group.rows++;
        group.sum += residuals[static_cast<size_t>(row)];
        group.members.push_back(row);
        groupOfRow[static_cast<size_t>(row)] = it->second;
      }
    }
  }
  // Per kind: the spread within the groups (w) and of their common parts (b).
  std::array<double, kKinds> withinSq{}, meanSq{}, within{}, between{};
  std::array<int, kKinds> rowCount{}, groupCount{};
  for (const SharedErrorModel::Group& g : groups) {
    const double mean = g.sum / g.rows;
    for (int r : g.members) {
      const double e = residuals[static_cast<size_t>(r)] - mean;
      withinSq[static_cast<size_t>(g.kind)] += e * e;
    }
    rowCount[static_cast<size_t>(g.kind)] += g.rows;
    groupCount[static_cast<size_t>(g.kind)] += 1;
  }
  for (int k = 0; k < kKinds; ++k) {
    const auto kk = static_cast<size_t>(k);
    const int dof = rowCount[kk] - groupCount[kk];
    within[kk] = std::max(1.0, dof > 0 ? withinSq[kk] / dof : 1.0);
  }
  for (const SharedErrorModel::Group& g : groups) {
    const auto kk = static_cast<size_t>(g.kind);
    const double mean = g.sum / g.rows;
    meanSq[kk] += mean * mean - within[kk] / g.rows;
  }
  for (int k = 0; k < kKinds; ++k) {
    const auto kk = static_cast<size_t>(k);
    between[kk] = groupCount[kk] > 1 ? std::max(0.0, meanSq[kk] / groupCount[kk]) : 0.0;
  }
  for (SharedErrorModel::Group& g : groups) {
    const auto kk = static_cast<size_t>(g.kind);
    g.coefficient = between[kk] / (within[kk] * (within[kk] + g.rows * between[kk]));
  }
  model.weights.assign(residuals.size(), 1.0);
  for (size_t r = 0; r < residuals.size(); ++r) {
    if (groupOfRow[r] >= 0)
      model.weights[r] =
          1.0 / within[static_cast<size_t>(groups[static_cast<size_t>(groupOfRow[r])].kind)];
  }
  result->sharedErrors = {std::sqrt(within[0]),  std::sqrt(within[1]),  std::sqrt(within[2]),
                          std::sqrt(between[0]), std::sqrt(between[1]), std::sqrt(between[2])};
  return model;
}

// The information JᵀΩ⁻¹J of the rows under `model`.
InformationBlocks sharedErrorInformation(const SharedErrorModel& model,
                                         const ceres::CRSMatrix& jacobian, int moduleCount,
                                         int sharedSize) {
  InformationBlocks info = informationFromJacobian(
      jacobian.num_rows, jacobian.num_cols, jacobian.rows, jacobian.cols, jacobian.values,
      moduleCount, kModuleTangentSize, sharedSize, &model.weights);
  const int sharedStart = moduleCount * kModuleTangentSize;
  for (const SharedErrorModel::Group& g : model.groups) {
    if (g.coefficient <= 0.0) continue;
    int module = -1;
    const Eigen::VectorXd sum = groupRowSum(jacobian, g.members, sharedStart, sharedSize, &module);
    subtractCommonPart(sum.head(kModuleTangentSize), sum.tail(sharedSize), module, g.coefficient,
                       &info);
  }
  return info;
}

// JᵀΩ⁻¹ D under `model` for the dense columns D (one row per Jacobian row): full-length
// columns over the Jacobian's [modules | shared] layout.
Eigen::MatrixXd crossInformation(const SharedErrorModel& model, const ceres::CRSMatrix& jacobian,
                                 const Eigen::MatrixXd& columns) {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(jacobian.num_cols, columns.cols());
  const auto addRow = [&](size_t r, const Eigen::RowVectorXd& weight) {
    for (int k = jacobian.rows[r]; k < jacobian.rows[r + 1]; ++k) {
      out.row(jacobian.cols[static_cast<size_t>(k)]) +=
          jacobian.values[static_cast<size_t>(k)] * weight;
    }
  };
  for (size_t r = 0; r < static_cast<size_t>(jacobian.num_rows); ++r)
    addRow(r, model.weights[r] * columns.row(static_cast<Eigen::Index>(r)));
  for (const SharedErrorModel::Group& g : model.groups) {
    if (g.coefficient <= 0.0) continue;
    Eigen::RowVectorXd sum = Eigen::RowVectorXd::Zero(columns.cols());
    for (int r : g.members) sum += columns.row(r);
    for (int r : g.members) addRow(static_cast<size_t>(r), -g.coefficient * sum);
  }
  return out;
}

// The score Σ JᵀΩ⁻¹r and the information JᵀΩ⁻¹J (under `model`) of the decoded rows of each
// (station, module), and of every other block alone, over [module | shared].
std::vector<ClusterScore> stationModuleScores(const FitProblem& built,
                                              const SharedErrorModel& model,
                                              const ceres::CRSMatrix& jacobian,
                                              const std::vector<double>& residuals, int moduleCount,
                                              int sharedSize) {
  const int sharedStart = moduleCount * kModuleTangentSize;
  const int size = kModuleTangentSize + sharedSize;
  struct Cluster {
    int module = -1;
    Eigen::VectorXd score;
    Eigen::MatrixXd information;
  };
  std::vector<Cluster> clusters;
  std::vector<size_t> clusterOfRow(residuals.size());
  std::unordered_map<std::int64_t, size_t> index;
  std::vector<std::pair<int, double>> nonzeros;
  size_t row = 0;
  for (size_t b = 0; b < built.residualBlocks.size(); ++b) {
    const auto rows = static_cast<size_t>(
        built.problem->GetCostFunctionForResidualBlock(built.residualBlocks[b])->num_residuals());
    // Both kinds of a (station, module) together; other blocks each alone (negative keys).
    const std::int64_t key =
        built.groupOf[b] >= 0 ? built.groupOf[b] / 2 : -1 - static_cast<std::int64_t>(b);
    const auto [it, fresh] = index.try_emplace(key, clusters.size());
    if (fresh)
      clusters.push_back({-1, Eigen::VectorXd::Zero(size), Eigen::MatrixXd::Zero(size, size)});
    Cluster& c = clusters[it->second];
    for (size_t r = row; r < row + rows; ++r) {
      // The row's few nonzeros (its module's and its camera's), not the dense outer product.
      clusterRowEntries(jacobian, r, sharedStart, &c.module, &nonzeros);
      const double w = model.weights[r];
      for (const auto& [i, vi] : nonzeros) {
        c.score[i] += w * residuals[r] * vi;
        for (const auto& [k, vk] : nonzeros) c.information(i, k) += w * vi * vk;
      }
      clusterOfRow[r] = it->second;
    }
    row += rows;
  }
  // A group's common part (Ω⁻¹'s −coefficient 11ᵀ): every group lies within one cluster.
  for (const SharedErrorModel::Group& g : model.groups) {
    if (g.coefficient <= 0.0 || g.members.empty()) continue;
    Cluster& c = clusters[clusterOfRow[static_cast<size_t>(g.members.front())]];
    int ignored = -1;
    const Eigen::VectorXd sum = groupRowSum(jacobian, g.members, sharedStart, sharedSize, &ignored);
    c.score -= g.coefficient * g.sum * sum;
    c.information.noalias() -= g.coefficient * sum * sum.transpose();
  }
  std::vector<ClusterScore> scores;
  scores.reserve(clusters.size());
  for (Cluster& c : clusters) {
    scores.push_back({c.module, c.score.head(kModuleTangentSize), c.score.tail(sharedSize),
                      std::move(c.information)});
  }
  return scores;
}

}  // namespace

void diagnoseUncertainty(const FitInputs& in, FitState& state, const NoiseLevels& sigmas,
                         FitProblem& built, const Eigen::MatrixXd& intrinsicsSensitivity,
                         FitResult* result) {
  const FitOptions& options = in.options;
  // ---- the Jacobian over the estimated blocks: modules first, then cameras and k ----
  std::vector<double*> blocks;
  std::vector<size_t> moduleOf;
  for (size_t m = 0; m < state.modules.size(); ++m) {
    if (in.observed[m] && !in.held[m]) {  // held modules are not estimated: no covariance
      blocks.push_back(state.modules[m].data());
      moduleOf.push_back(m);
    }
  }
  for (auto& cam : state.cameras) blocks.push_back(cam.data());
  if (options.fitCurvature) blocks.push_back(&state.k);
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  eo.residual_blocks = built.residualBlocks;
  eo.apply_loss_function = true;
  eo.num_threads = options.threads;
  ceres::CRSMatrix jacobian;
  std::vector<double> residuals;
  double cost = 0.0;
  const int sharedSize =
      kCameraTangentSize * static_cast<int>(state.cameras.size()) + (options.fitCurvature ? 1 : 0);
  if (!built.problem->Evaluate(eo, &cost, &residuals, nullptr, &jacobian)) {
    result->notes.push_back("the Jacobian could not be evaluated at the solution");
    result->converged = false;
    return;
  }
  const SharedErrorModel errors = sharedErrorModel(built, residuals, result);
  const InformationBlocks info =
      sharedErrorInformation(errors, jacobian, static_cast<int>(moduleOf.size()), sharedSize);
  Diagnostics d = diagnose(info, options.conditioning);
  // How the answer moves with the camera intrinsics held at the checkerboard's estimate
  // (intrinsics_sensitivity.h), solved before the widening below changes Σ_ss.
  Eigen::MatrixXd intrinsicsShift;
  if (intrinsicsSensitivity.rows() == jacobian.num_rows) {
    intrinsicsShift = solveInformation(info, d, options.conditioning,
                                       crossInformation(errors, jacobian, intrinsicsSensitivity));
  } else if (!in.obs.intrinsicsCovariance.isZero()) {
    result->notes.push_back(
        "the camera intrinsics' uncertainty could not be carried into the σ (their effect on "
        "the residuals could not be evaluated): the σ leave it out");
  } else if (in.obs.cameraResponse) {
    // Decoded from pictures with intrinsics that came without a covariance (camera.json).
    result->notes.push_back(
        "the σ take the camera's intrinsics as exact (camera.json gives no covariance): "
        "calibrate the camera from its checkerboard pictures (`parallax camera`) so that their "
        "uncertainty is counted");
  }
  // What the residuals themselves say, station by station: a station's decoding of a module
  // that is off as a whole moves the module more than independent errors could.
  widenToClusterRobust(info,
                       stationModuleScores(built, errors, jacobian, residuals,
                                           static_cast<int>(moduleOf.size()), sharedSize),
                       options.conditioning, &d);
  if (intrinsicsShift.size() > 0) {
    addCarriedCovariance(intrinsicsShift, in.obs.intrinsicsCovariance, &d);
    result->intrinsicsCarried = true;
  }

  // ---- modules ----
  for (size_t j = 0; j < moduleOf.size(); ++j) {
    ModuleFit& mf = result->modules[moduleOf[j]];
    mf.conditioning = d.modules[j];
    const double width = in.nominal.modules[moduleOf[j]].width;
    for (int p = 0; p < kModuleTangentSize; ++p) {
      double sd = d.moduleStdDev[j][p];
      if (p < 3)
        sd *= kTangentToRotationDeg;
      else if (p < 6)
        sd *= 1e3;
      else if (p < 10)
        sd *= width;
      mf.stdDev[static_cast<size_t>(p)] = sd;
    }
    // The module's covariance joined with k's, for the gate (ray_uncertainty.h): its rays
    // depend on both, and the two estimates are correlated.
    Eigen::MatrixXd& cov = mf.rayCovariance;
    cov = Eigen::MatrixXd::Zero(kModuleTangentSize + 1, kModuleTangentSize + 1);
    cov.topLeftCorner(kModuleTangentSize, kModuleTangentSize) = d.moduleCovariance[j];
    if (options.fitCurvature) {
      const Eigen::VectorXd cross = d.moduleSharedCovariance[j].col(sharedSize - 1);
      cov.block(0, kModuleTangentSize, kModuleTangentSize, 1) = cross;
      cov.block(kModuleTangentSize, 0, 1, kModuleTangentSize) = cross.transpose();
      cov(kModuleTangentSize, kModuleTangentSize) =
          d.sharedCovariance(sharedSize - 1, sharedSize - 1);
    }
    for (int p = 0; p < kModuleTangentSize; ++p) {
      if (!std::isfinite(d.moduleStdDev[j][p])) cov(p, p) = std::numeric_limits<double>::infinity();
    }
    if (d.modules[j].state != Conditioning::kGood) {
      Deficiency def;
      def.module = static_cast<int>(moduleOf[j]);
      def.state = d.modules[j].state;
      def.reciprocalCondition = d.modules[j].reciprocalCondition;
      for (int p : d.modules[j].nullDirection) def.parameters.push_back(moduleParameterName(p));
      result->deficiencies.push_back(def);
    }
  }

  // ---- cameras and k ----
  for (size_t c = 0; c < state.cameras.size(); ++c) {
    for (int p = 0; p < kCameraTangentSize; ++p) {
      double sd = d.sharedStdDev[static_cast<long>(c) * kCameraTangentSize + p];
      sd *= p < 3 ? kTangentToRotationDeg : 1e3;
      result->cameras[c].stdDev[static_cast<size_t>(p)] = sd;
    }
  }
  result->curvatureStdDev = options.fitCurvature ? d.sharedStdDev[sharedSize - 1] : 0.0;
  if (d.shared.state != Conditioning::kGood) {
    Deficiency def;
    def.module = -1;
    def.state = d.shared.state;
    def.reciprocalCondition = d.shared.reciprocalCondition;
    for (int p : d.shared.nullDirection) {
      if (options.fitCurvature && p == sharedSize - 1) {
        def.parameters.push_back("screen curvature k");
      } else {
        def.parameters.push_back(fmt::format("camera {} {}", p / kCameraTangentSize,
                                             cameraParameterName(p % kCameraTangentSize)));
      }
    }
    result->deficiencies.push_back(def);
  }
}

}  // namespace parallax::fit
