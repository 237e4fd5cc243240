#include "tracer/mesh_shapes.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "common/check.h"

namespace parallax {
namespace {

constexpr double kPi = std::numbers::pi;

std::uint32_t addVertex(Mesh* m, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double u,
                        double v) {
  m->positions.push_back(p);
  m->normals.push_back(n.normalized().cast<float>());
  m->uvs.push_back({static_cast<float>(u), static_cast<float>(v)});
  return static_cast<std::uint32_t>(m->positions.size() - 1);
}

// Quad a-b-c-d counter-clockwise seen from its front.
void addQuad(Mesh* m, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d) {
  m->triangles.push_back({a, b, c});
  m->triangles.push_back({a, c, d});
}

}  // namespace

namespace {

// The distance from p to the triangle abc (its nearest point by the triangle's regions: Ericson,
// Real-Time Collision Detection, 5.1.5).
double distanceToTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return (p - a).norm();
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return (p - b).norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return (p - (a + d1 / (d1 - d3) * ab)).norm();
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return (p - c).norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return (p - (a + d2 / (d2 - d6) * ac)).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0)
    return (p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  const double denominator = 1.0 / (va + vb + vc);
  return (p - (a + ab * (vb * denominator) + ac * (vc * denominator))).norm();
}

// Spheres about `centres` (each inside the closed mesh), as large as their distance from the
// triangles allows, less 0.1%: a sphere that meets no triangle lies wholly on its centre's side.
void addInterior(Mesh* m, const std::vector<Eigen::Vector3d>& centres) {
  for (const Eigen::Vector3d& centre : centres) {
    double radius = std::numeric_limits<double>::infinity();
    for (const auto& t : m->triangles) {
      radius = std::min(radius, distanceToTriangle(centre, m->positions[t[0]], m->positions[t[1]],
                                                   m->positions[t[2]]));
    }
    radius *= 1.0 - 1e-3;
    if (radius > 0.0 && std::isfinite(radius))
      m->interior.emplace_back(centre.x(), centre.y(), centre.z(), radius);
  }
}

}  // namespace

Mesh makeGrid(double width, double height, int nx, int ny) {
  PARALLAX_CHECK(nx >= 1 && ny >= 1);
  Mesh m;
  m.name = "grid";
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) {
      const double u = static_cast<double>(i) / nx, v = static_cast<double>(j) / ny;
      addVertex(&m, {(u - 0.5) * width, (v - 0.5) * height, 0.0}, {0, 0, 1}, u, v);
    }
  }
  const auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (nx + 1) + i); };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i)
      addQuad(&m, at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
  }
  return m;
}

Mesh makeBox(const Eigen::Vector3d& size) {
  Mesh m;
  m.name = "box";
  const Eigen::Vector3d h = 0.5 * size;
  // Each face: outward normal n and two in-plane axes a, b with a × b = n.
  const Eigen::Vector3d axes[6][3] = {
      {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{-1, 0, 0}, {0, 0, 1}, {0, 1, 0}},
      {{0, 1, 0}, {0, 0, 1}, {1, 0, 0}}, {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}},
      {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}}, {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}}};
  for (const auto& face : axes) {
    const Eigen::Vector3d& n = face[0];
    const Eigen::Vector3d a = face[1].cwiseProduct(h), b = face[2].cwiseProduct(h),
                          c = n.cwiseProduct(h);
    const std::uint32_t v0 = addVertex(&m, c - a - b, n, 0, 0);
    const std::uint32_t v1 = addVertex(&m, c + a - b, n, 1, 0);
    const std::uint32_t v2 = addVertex(&m, c + a + b, n, 1, 1);
    const std::uint32_t v3 = addVertex(&m, c - a + b, n, 0, 1);
    addQuad(&m, v0, v1, v2, v3);
  }
  addInterior(&m, {Eigen::Vector3d::Zero()});
  return m;
}

Mesh makeSphere(double radius, int slices, int stacks) {
  PARALLAX_CHECK(slices >= 3 && stacks >= 2);
  Mesh m;
  m.name = "sphere";
  for (int j = 0; j <= stacks; ++j) {
    const double theta = kPi * j / stacks;  // from the north pole (+y)
    for (int i = 0; i <= slices; ++i) {
      const double phi = 2.0 * kPi * i / slices;
      const Eigen::Vector3d n(std::sin(theta) * std::sin(phi), std::cos(theta),
                              std::sin(theta) * std::cos(phi));
      addVertex(&m, radius * n, n, static_cast<double>(i) / slices,
                1.0 - static_cast<double>(j) / stacks);
    }
  }
  const auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (slices + 1) + i); };
  for (int j = 0; j < stacks; ++j) {
    for (int i = 0; i < slices; ++i) {
      // Counter-clockwise seen from outside: down the meridian, then along increasing phi.
      if (j > 0) m.triangles.push_back({at(i, j), at(i, j + 1), at(i + 1, j)});
      if (j + 1 < stacks) m.triangles.push_back({at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)});
    }
  }
  addInterior(&m, {Eigen::Vector3d::Zero()});  // known here, not worked out every frame
  return m;
}

Mesh makeTorus(double majorRadius, double minorRadius, int segments, int sides) {
  PARALLAX_CHECK(segments >= 3 && sides >= 3);
  Mesh m;
  m.name = "torus";
  for (int j = 0; j <= segments; ++j) {
    const double phi = 2.0 * kPi * j / segments;
    const Eigen::Vector3d radial(std::sin(phi), 0.0, std::cos(phi));
    for (int i = 0; i <= sides; ++i) {
      const double psi = 2.0 * kPi * i / sides;
      const Eigen::Vector3d n = std::cos(psi) * radial + std::sin(psi) * Eigen::Vector3d::UnitY();
      addVertex(&m, majorRadius * radial + minorRadius * n, n, static_cast<double>(j) / segments,
                static_cast<double>(i) / sides);
    }
  }
  const auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (sides + 1) + i); };
  for (int j = 0; j < segments; ++j) {
    for (int i = 0; i < sides; ++i)
      addQuad(&m, at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
  }
  // Along the core circle, on the rings of corners (where the tube is widest).
  const int beads = std::min(segments, 24);
  std::vector<Eigen::Vector3d> centres;
  for (int k = 0; k < beads; ++k) {
    const double phi = 2.0 * kPi * std::round(static_cast<double>(k) * segments / beads) / segments;
    centres.push_back(majorRadius * Eigen::Vector3d(std::sin(phi), 0.0, std::cos(phi)));
  }
  addInterior(&m, centres);
  // Every corner lies minorRadius from the core circle; the faces between them reach no farther
  // out, and inward no nearer the axis than the chord between two rings' innermost corners.
  m.ring.inner = (majorRadius - minorRadius) * std::cos(kPi / segments);
  m.ring.outer = majorRadius + minorRadius;
  m.ring.halfHeight = minorRadius;
  return m;
}

Mesh makeCylinder(double radius, double height, int slices) {
  PARALLAX_CHECK(slices >= 3);
  Mesh m;
  m.name = "cylinder";
  const double h = 0.5 * height;
  for (int i = 0; i < slices; ++i) {
    const double a0 = 2.0 * kPi * i / slices, a1 = 2.0 * kPi * (i + 1) / slices;
    const Eigen::Vector3d n0(std::sin(a0), 0, std::cos(a0)), n1(std::sin(a1), 0, std::cos(a1));
    const double u0 = static_cast<double>(i) / slices, u1 = static_cast<double>(i + 1) / slices;
    const std::uint32_t b0 = addVertex(&m, radius * n0 + Eigen::Vector3d(0, -h, 0), n0, u0, 0);
    const std::uint32_t b1 = addVertex(&m, radius * n1 + Eigen::Vector3d(0, -h, 0), n1, u1, 0);
    const std::uint32_t t1 = addVertex(&m, radius * n1 + Eigen::Vector3d(0, h, 0), n1, u1, 1);
    const std::uint32_t t0 = addVertex(&m, radius * n0 + Eigen::Vector3d(0, h, 0), n0, u0, 1);
    addQuad(&m, b0, b1, t1, t0);
    // Caps: fans from the centres, flat normals.
    const Eigen::Vector3d up(0, 1, 0);
    const std::uint32_t ct = addVertex(&m, {0, h, 0}, up, 0.5, 0.5);
    const std::uint32_t ct0 = addVertex(&m, radius * n0 + Eigen::Vector3d(0, h, 0), up,
                                        0.5 + 0.5 * n0.x(), 0.5 + 0.5 * n0.z());
    const std::uint32_t ct1 = addVertex(&m, radius * n1 + Eigen::Vector3d(0, h, 0), up,
                                        0.5 + 0.5 * n1.x(), 0.5 + 0.5 * n1.z());
    m.triangles.push_back({ct, ct0, ct1});
    const std::uint32_t cb = addVertex(&m, {0, -h, 0}, -up, 0.5, 0.5);
    const std::uint32_t cb0 = addVertex(&m, radius * n0 + Eigen::Vector3d(0, -h, 0), -up,
                                        0.5 + 0.5 * n0.x(), 0.5 + 0.5 * n0.z());
    const std::uint32_t cb1 = addVertex(&m, radius * n1 + Eigen::Vector3d(0, -h, 0), -up,
                                        0.5 + 0.5 * n1.x(), 0.5 + 0.5 * n1.z());
    m.triangles.push_back({cb, cb1, cb0});
  }
  return m;
}

Mesh makeCone(double radius, double height, int slices) {
  PARALLAX_CHECK(slices >= 3);
  Mesh m;
  m.name = "cone";
  const double h = 0.5 * height;
  const double slope = radius / height;  // normal tilt: (cos a, slope, sin a) normalised
  for (int i = 0; i < slices; ++i) {
    const double a0 = 2.0 * kPi * i / slices, a1 = 2.0 * kPi * (i + 1) / slices,
                 am = 0.5 * (a0 + a1);
    const Eigen::Vector3d r0(std::sin(a0), 0, std::cos(a0)), r1(std::sin(a1), 0, std::cos(a1)),
        rm(std::sin(am), 0, std::cos(am));
    const std::uint32_t b0 = addVertex(&m, radius * r0 + Eigen::Vector3d(0, -h, 0),
                                       r0 + Eigen::Vector3d(0, slope, 0), 0, 0);
    const std::uint32_t b1 = addVertex(&m, radius * r1 + Eigen::Vector3d(0, -h, 0),
                                       r1 + Eigen::Vector3d(0, slope, 0), 1, 0);
    const std::uint32_t apex = addVertex(&m, {0, h, 0}, rm + Eigen::Vector3d(0, slope, 0), 0.5, 1);
    m.triangles.push_back({b0, b1, apex});
    const Eigen::Vector3d down(0, -1, 0);
    const std::uint32_t c = addVertex(&m, {0, -h, 0}, down, 0.5, 0.5);
    const std::uint32_t c0 = addVertex(&m, radius * r0 + Eigen::Vector3d(0, -h, 0), down, 0, 0);
    const std::uint32_t c1 = addVertex(&m, radius * r1 + Eigen::Vector3d(0, -h, 0), down, 1, 0);
    m.triangles.push_back({c, c1, c0});
  }
  return m;
}

}  // namespace parallax
