#include "calibration/fit/fit_diagnostics.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <random>

namespace parallax {
namespace {

// Two modules of 2 parameters (rows 0-3 and 4-7) and 1 shared parameter.
Eigen::MatrixXd twoModules() {
  Eigen::MatrixXd j(8, 5);
  j << 1, 0.3, 0, 0, 0.5,  //
      0.2, 1, 0, 0, 0.1,   //
      0.7, -0.4, 0, 0, 1,  //
      1, 1, 0, 0, 0,       //
      0, 0, 1, 0.1, -0.3,  //
      0, 0, 0.4, 1, 0.8,   //
      0, 0, -1, 0.5, 0.2,  //
      0, 0, 0.3, 0.3, 1;
  return j;
}

// A dense Jacobian as Ceres' CRSMatrix fields.
struct SparseRows {
  explicit SparseRows(const Eigen::MatrixXd& j) {
    for (Eigen::Index r = 0; r < j.rows(); ++r) {
      for (Eigen::Index c = 0; c < j.cols(); ++c) {
        if (j(r, c) != 0.0) {
          cols.push_back(static_cast<int>(c));
          values.push_back(j(r, c));
        }
      }
      rows.push_back(static_cast<int>(cols.size()));
    }
  }
  std::vector<int> rows{0}, cols;
  std::vector<double> values;
};

TEST(FitDiagnostics, NamesTheParametersThatCannotBeSeparated) {
  // Columns 1 and 2 of the Jacobian are identical up to scale (think focal length and
  // distance): the information block is singular along (0, 2, −1)/√5 in scaled terms.
  Eigen::MatrixXd j(6, 3);
  j << 1, 2, 4, 0, 1, 2, 1, 0, 0, 0, 3, 6, 2, 1, 2, 1, 1, 2;
  const Eigen::MatrixXd h = j.transpose() * j;
  const BlockConditioning c = conditioningOf(h, {});
  EXPECT_EQ(c.state, Conditioning::kRankDeficient);
  ASSERT_EQ(c.nullDirection.size(), 2u);
  EXPECT_TRUE((c.nullDirection[0] == 1 && c.nullDirection[1] == 2) ||
              (c.nullDirection[0] == 2 && c.nullDirection[1] == 1));
}

TEST(FitDiagnostics, UnitsDoNotMatter) {
  // A well-posed block stays well posed when one parameter is measured in units a million
  // times smaller: conditioning is judged on the unit-diagonal scaling.
  Eigen::MatrixXd j(4, 2);
  j << 1, 0.2, 0.3, 1, 1, 1, 0.5, -1;
  Eigen::MatrixXd scaled = j;
  scaled.col(1) *= 1e6;
  EXPECT_EQ(conditioningOf(j.transpose() * j, {}).state, Conditioning::kGood);
  EXPECT_EQ(conditioningOf(scaled.transpose() * scaled, {}).state, Conditioning::kGood);
}

TEST(FitDiagnostics, SchurMarginalsMatchTheFullInverse) {
  // Two modules of 2 parameters and 1 shared parameter: the std devs from the Schur route
  // equal the square roots of the diagonal of the full (JᵀJ)⁻¹.
  const Eigen::MatrixXd j = twoModules();
  const SparseRows sparse(j);
  const InformationBlocks info =
      informationFromJacobian(8, 5, sparse.rows, sparse.cols, sparse.values, 2, 2, 1);
  const Diagnostics d = diagnose(info, {});
  const Eigen::MatrixXd h = j.transpose() * j;
  const Eigen::MatrixXd full = h.inverse();
  EXPECT_NEAR(d.moduleStdDev[0][0], std::sqrt(full(0, 0)), 1e-10);
  EXPECT_NEAR(d.moduleStdDev[0][1], std::sqrt(full(1, 1)), 1e-10);
  EXPECT_NEAR(d.moduleStdDev[1][0], std::sqrt(full(2, 2)), 1e-10);
  EXPECT_NEAR(d.moduleStdDev[1][1], std::sqrt(full(3, 3)), 1e-10);
  EXPECT_NEAR(d.sharedStdDev[0], std::sqrt(full(4, 4)), 1e-10);
}

TEST(FitDiagnostics, RowsSharingACommonErrorInformAsTheirCorrelatedCovarianceSays) {
  // The same two modules; rows 0-3 (module 0) share a common error: their covariance is
  // w I + b 11ᵀ. Row weights 1/w and the common part taken out give the generalized least
  // squares information Jᵀ Σ⁻¹ J exactly, and its σ are larger than the independent rows'.
  const Eigen::MatrixXd j = twoModules();
  const SparseRows sparse(j);
  const double w = 1.5, b = 0.8;
  const int n = 4;
  const std::vector<double> weights{1 / w, 1 / w, 1 / w, 1 / w, 1, 1, 1, 1};
  InformationBlocks info =
      informationFromJacobian(8, 5, sparse.rows, sparse.cols, sparse.values, 2, 2, 1, &weights);
  const Eigen::VectorXd sum = j.topRows(n).colwise().sum().transpose();
  subtractCommonPart(sum.head(2), sum.tail(1), 0, b / (w * (w + n * b)), &info);
  const Diagnostics d = diagnose(info, {});

  Eigen::MatrixXd covariance = Eigen::MatrixXd::Identity(8, 8);
  covariance.topLeftCorner(n, n) =
      w * Eigen::MatrixXd::Identity(n, n) + b * Eigen::MatrixXd::Ones(n, n);
  const Eigen::MatrixXd full = (j.transpose() * covariance.inverse() * j).inverse();
  const Eigen::MatrixXd independent = (j.transpose() * j).inverse();
  for (int p = 0; p < 2; ++p) {
    EXPECT_NEAR(d.moduleStdDev[0][p], std::sqrt(full(p, p)), 1e-10);
    EXPECT_NEAR(d.moduleStdDev[1][p], std::sqrt(full(2 + p, 2 + p)), 1e-10);
    EXPECT_GT(d.moduleStdDev[0][p], 1.05 * std::sqrt(independent(p, p)));
  }
  EXPECT_NEAR(d.sharedStdDev[0], std::sqrt(full(4, 4)), 1e-10);
}

// A fit of modules seen by a few stations each, every station's rows of a module alike (a
// station sees a module's pixels from one side), with unit noise plus `common` × an offset per
// (station, module). The truth is 0: the estimate is its own error.
struct ClusterFit {
  std::vector<double> error;    // per module parameter
  std::vector<double> model;    // the model's σ
  std::vector<double> widened;  // after widenToClusterRobust
};

ClusterFit fitClusters(double common, int stations, bool leverage, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  constexpr int kModules = 2, kModuleSize = 3, kShared = 2, kRows = 40;
  const int cols = kModules * kModuleSize + kShared;
  const int clusterSize = kModuleSize + kShared;
  const int numRows = kModules * stations * kRows;
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(numRows, cols);
  Eigen::VectorXd e(numRows);
  int r = 0;
  for (int m = 0; m < kModules; ++m) {
    for (int s = 0; s < stations; ++s) {
      const double offset = common * normal(rng);
      const Eigen::Vector3d alike(normal(rng), normal(rng), normal(rng));
      for (int k = 0; k < kRows; ++k, ++r) {
        e[r] = normal(rng) + offset;
        for (int c = 0; c < kModuleSize; ++c)
          j(r, m * kModuleSize + c) = alike[c] + 0.5 * normal(rng);
        for (int c = 0; c < kShared; ++c) j(r, kModules * kModuleSize + c) = 0.5 * normal(rng);
      }
    }
  }
  // The fit, and its residuals at the solution: what a real fit's scores are made of.
  const Eigen::VectorXd estimate = (j.transpose() * j).ldlt().solve(j.transpose() * e);
  const Eigen::VectorXd residual = e - j * estimate;
  std::vector<ClusterScore> scores;
  for (int c = 0; c < kModules * stations; ++c) {
    const int m = c / stations;
    Eigen::MatrixXd rows(kRows, clusterSize);
    rows << j.block(c * kRows, m * kModuleSize, kRows, kModuleSize),
        j.block(c * kRows, kModules * kModuleSize, kRows, kShared);
    const Eigen::VectorXd score = rows.transpose() * residual.segment(c * kRows, kRows);
    ClusterScore cluster{m, score.head(kModuleSize), score.tail(kShared), {}};
    if (leverage) cluster.information = rows.transpose() * rows;
    scores.push_back(cluster);
  }
  const SparseRows sparse(j);
  const InformationBlocks info = informationFromJacobian(
      numRows, cols, sparse.rows, sparse.cols, sparse.values, kModules, kModuleSize, kShared);
  const Diagnostics model = diagnose(info, {});
  Diagnostics widened = model;
  widenToClusterRobust(info, scores, {}, &widened);
  ClusterFit out;
  for (int m = 0; m < kModules; ++m) {
    for (int p = 0; p < kModuleSize; ++p) {
      out.error.push_back(estimate[m * kModuleSize + p]);
      out.model.push_back(model.moduleStdDev[m][p]);
      out.widened.push_back(widened.moduleStdDev[static_cast<size_t>(m)][p]);
    }
  }
  return out;
}

TEST(FitDiagnostics, ErrorsAStationSharesAcrossAModuleWidenItsSigma) {
  for (bool leverage : {false, true}) {
    // Independent rows: the model's σ stand (the widening's expectation is 1, never below).
    const ClusterFit independent = fitClusters(0.0, 5, leverage, 17);
    for (size_t p = 0; p < independent.model.size(); ++p) {
      const double ratio = independent.widened[p] / independent.model[p];
      EXPECT_GE(ratio, 1.0);
      EXPECT_LT(ratio, 1.6);
    }
    // A common offset per (station, module) of the rows' own size: 40 rows then know no more
    // than about one, and the σ say so.
    const ClusterFit shared = fitClusters(1.0, 5, leverage, 17);
    for (size_t p = 0; p < shared.model.size(); ++p)
      EXPECT_GT(shared.widened[p] / shared.model[p], leverage ? 2.0 : 1.5);
  }
}

// Five stations a module, each decode off as a whole by a third of its rows' noise: the module's 3
// parameters absorb much of what each decode shares, so the raw residuals understate it. Over
// many fits the true error is well beyond the raw sandwich's σ, and near the σ once each
// station's leverage is corrected for (CR2).
TEST(FitDiagnostics, TheLeverageOfAFewStationsIsCorrectedFor) {
  double raw = 0.0, corrected = 0.0;
  int n = 0;
  for (unsigned seed = 1; seed <= 200; ++seed) {
    const ClusterFit plain = fitClusters(0.3, 5, false, seed);
    const ClusterFit cr2 = fitClusters(0.3, 5, true, seed);
    for (size_t p = 0; p < plain.error.size(); ++p, ++n) {
      ASSERT_EQ(plain.error[p], cr2.error[p]);
      raw += std::pow(plain.error[p] / plain.widened[p], 2);
      corrected += std::pow(cr2.error[p] / cr2.widened[p], 2);
    }
  }
  // The mean square of error / σ: 1 when the σ are right (measured: raw 1.99, CR2 1.39).
  EXPECT_GT(raw / n, 1.7);
  EXPECT_LT(corrected / n, 1.6);
  EXPECT_GT(corrected / n, 0.7);
}

TEST(FitDiagnostics, AnUnseenParameterIsUndetermined) {
  Eigen::MatrixXd h = Eigen::MatrixXd::Identity(3, 3);
  h(2, 2) = 0.0;
  const BlockConditioning c = conditioningOf(h, {});
  EXPECT_EQ(c.state, Conditioning::kRankDeficient);
  ASSERT_EQ(c.nullDirection.size(), 1u);
  EXPECT_EQ(c.nullDirection[0], 2);
}

}  // namespace
}  // namespace parallax
