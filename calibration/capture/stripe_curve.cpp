#include "calibration/capture/stripe_curve.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace parallax {
namespace {

double median(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

std::vector<bool> stripeCentresOnCurve(const std::vector<Eigen::Vector2d>& centres,
                                       const StripeCurveOptions& options) {
  const int n = static_cast<int>(centres.size());
  std::vector<bool> kept(centres.size(), false);
  if (n < std::max(options.minRows, options.degree + 2)) return kept;
  // y about the stripe's middle, in half-spans: keeps the Vandermonde system well conditioned.
  double yMin = centres[0].y(), yMax = yMin;
  for (const auto& c : centres) {
    yMin = std::min(yMin, c.y());
    yMax = std::max(yMax, c.y());
  }
  const double mid = 0.5 * (yMin + yMax), half = std::max(0.5 * (yMax - yMin), 1.0);
  const int terms = options.degree + 1;
  Eigen::MatrixXd basis(n, terms);
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) {
    const double t = (centres[static_cast<size_t>(i)].y() - mid) / half;
    double power = 1.0;
    for (int d = 0; d < terms; ++d, power *= t) basis(i, d) = power;
    x[i] = centres[static_cast<size_t>(i)].x();
  }
  // Least squares on the centres still in, a few rounds: the first round is pulled by the
  // fragments, the next ones by the rest only.
  std::fill(kept.begin(), kept.end(), true);
  for (int round = 0; round < 4; ++round) {
    std::vector<int> in;
    for (int i = 0; i < n; ++i)
      if (kept[static_cast<size_t>(i)]) in.push_back(i);
    if (static_cast<int>(in.size()) < terms + 1) {
      std::fill(kept.begin(), kept.end(), false);
      return kept;
    }
    Eigen::MatrixXd a(static_cast<long>(in.size()), terms);
    Eigen::VectorXd b(static_cast<long>(in.size()));
    for (size_t r = 0; r < in.size(); ++r) {
      a.row(static_cast<long>(r)) = basis.row(in[r]);
      b[static_cast<long>(r)] = x[in[r]];
    }
    const Eigen::VectorXd coefficients = a.colPivHouseholderQr().solve(b);
    const Eigen::VectorXd residual = x - basis * coefficients;
    std::vector<double> absIn;
    for (int i : in) absIn.push_back(std::abs(residual[i]));
    const double limit =
        std::max(options.outlierSigmas * 1.4826 * median(absIn), options.minOutlierPx);
    for (int i = 0; i < n; ++i) kept[static_cast<size_t>(i)] = std::abs(residual[i]) <= limit;
  }
  return kept;
}

}  // namespace parallax
