#include "calibration/fit/fit_diagnostics.h"

#include <gtest/gtest.h>

#include <Eigen/LU>

namespace parallax {
namespace {

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
  Eigen::MatrixXd j(8, 5);
  j << 1, 0.3, 0, 0, 0.5,  //
      0.2, 1, 0, 0, 0.1,   //
      0.7, -0.4, 0, 0, 1,  //
      1, 1, 0, 0, 0,       //
      0, 0, 1, 0.1, -0.3,  //
      0, 0, 0.4, 1, 0.8,   //
      0, 0, -1, 0.5, 0.2,  //
      0, 0, 0.3, 0.3, 1;
  std::vector<int> rows{0}, cols;
  std::vector<double> values;
  for (int r = 0; r < 8; ++r) {
    for (int c = 0; c < 5; ++c) {
      if (j(r, c) != 0.0) {
        cols.push_back(c);
        values.push_back(j(r, c));
      }
    }
    rows.push_back(static_cast<int>(cols.size()));
  }
  const InformationBlocks info = informationFromJacobian(8, 5, rows, cols, values, 2, 2, 1);
  const Diagnostics d = diagnose(info, {});
  const Eigen::MatrixXd h = j.transpose() * j;
  const Eigen::MatrixXd full = h.inverse();
  EXPECT_NEAR(d.moduleStdDev[0][0], std::sqrt(full(0, 0)), 1e-10);
  EXPECT_NEAR(d.moduleStdDev[0][1], std::sqrt(full(1, 1)), 1e-10);
  EXPECT_NEAR(d.moduleStdDev[1][0], std::sqrt(full(2, 2)), 1e-10);
  EXPECT_NEAR(d.moduleStdDev[1][1], std::sqrt(full(3, 3)), 1e-10);
  EXPECT_NEAR(d.sharedStdDev[0], std::sqrt(full(4, 4)), 1e-10);
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
