#pragma once
// Tessellated primitives for fixtures and scripts: counter-clockwise outward triangles, smooth
// normals where the surface is smooth, UVs over [0, 1]². Object space, centred at the origin
// unless stated.

#include "tracer/scene.h"

namespace parallax {

// A rectangle in the x–y plane facing +z, w × h, split into nx × ny quads (2 nx ny triangles).
Mesh makeGrid(double width, double height, int nx, int ny);
// An axis-aligned box of the given size, flat faces (12 triangles). Its interior: the sphere
// about its centre as wide as its thinnest side allows.
Mesh makeBox(const Eigen::Vector3d& size);
// A UV sphere: 2 · slices · (stacks − 1) triangles. Its interior: the sphere about its centre
// that touches its nearest face.
Mesh makeSphere(double radius, int slices, int stacks);
// A torus around the y axis: 2 · segments · sides triangles. Its interior holds up to 24 spheres
// along its core circle, each as large as its distance from the triangles allows; its ring
// (Mesh::ring) bounds it tighter than a sphere, a ray through its hole misses it.
Mesh makeTorus(double majorRadius, double minorRadius, int segments, int sides);
// A closed cylinder along y from −h/2 to h/2: 4 · slices triangles.
Mesh makeCylinder(double radius, double height, int slices);
// A closed cone along y, base at −h/2: 2 · slices triangles.
Mesh makeCone(double radius, double height, int slices);

}  // namespace parallax
