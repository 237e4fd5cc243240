#include "calibration/fit/fit_diagnostics.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
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

// Two modules of 3 parameters, 2 shared; each module seen by 5 stations of 40 alike rows. Returns
// the module σ after widenToClusterRobust over the model's, for residuals that are independent unit
// noise, plus `common` × a per (station, module) offset.
std::vector<double> widenedOverModel(double common) {
  std::mt19937 rng(17);
  std::normal_distribution<double> normal;
  constexpr int kModules = 2, kModuleSize = 3, kShared = 2, kStations = 5, kRows = 40;
  const int cols = kModules * kModuleSize + kShared;
  std::vector<int> rows{0}, columns;
  std::vector<double> values, residuals;
  std::vector<ClusterScore> scores;
  for (int m = 0; m < kModules; ++m) {
    for (int s = 0; s < kStations; ++s) {
      ClusterScore score;
      score.module = m;
      score.modulePart = Eigen::VectorXd::Zero(kModuleSize);
      score.sharedPart = Eigen::VectorXd::Zero(kShared);
      const double offset = common * normal(rng);
      // A station sees a module's pixels from one side: its rows' derivatives are alike.
      Eigen::Vector3d alike(normal(rng), normal(rng), normal(rng));
      for (int r = 0; r < kRows; ++r) {
        const double residual = normal(rng) + offset;
        for (int c = 0; c < kModuleSize; ++c) {
          const double v = alike[c] + 0.5 * normal(rng);
          columns.push_back(m * kModuleSize + c);
          values.push_back(v);
          score.modulePart[c] += v * residual;
        }
        for (int c = 0; c < kShared; ++c) {
          const double v = 0.5 * normal(rng);
          columns.push_back(kModules * kModuleSize + c);
          values.push_back(v);
          score.sharedPart[c] += v * residual;
        }
        rows.push_back(static_cast<int>(columns.size()));
      }
      scores.push_back(score);
    }
  }
  const int numRows = static_cast<int>(rows.size()) - 1;
  const InformationBlocks info =
      informationFromJacobian(numRows, cols, rows, columns, values, kModules, kModuleSize, kShared);
  const Diagnostics model = diagnose(info, {});
  Diagnostics widened = model;
  widenToClusterRobust(info, scores, {}, &widened);
  std::vector<double> ratio;
  for (int m = 0; m < kModules; ++m) {
    for (int p = 0; p < kModuleSize; ++p)
      ratio.push_back(widened.moduleStdDev[m][p] / model.moduleStdDev[m][p]);
  }
  return ratio;
}

TEST(FitDiagnostics, ErrorsAStationSharesAcrossAModuleWidenItsSigma) {
  // Independent rows: the model's σ stand (the widening's expectation is 1, never below).
  for (double r : widenedOverModel(0.0)) {
    EXPECT_GE(r, 1.0);
    EXPECT_LT(r, 1.6);
  }
  // A common offset per (station, module) of the rows' own size: 40 rows then know no more
  // than about one, and the σ say so.
  for (double r : widenedOverModel(1.0)) EXPECT_GT(r, 2.0);
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
