// BandLaplacianDeformer's split of the free band into its connected pieces
// (laplacian_deformation.h): the pieces, factored and solved separately and concurrently, give
// the solution of one factorisation of the whole band; a piece without a handle is reported.
#include "geometry/garment/laplacian_deformation.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "geometry/mesh/primitives.h"

namespace vfit {
namespace {

// Two tubes 1 m apart along X, each 0.4 m long with its bottom and top quarter as handles
// (the second tube's only when `second_has_handles`): 2 × 3,600 free vertices, above
// BAND_SUPERNODAL_UNKNOWNS, so AUTO splits the band.
struct TwoTubes {
  Mesh mesh;
  std::vector<std::int32_t> handles;
  explicit TwoTubes(bool second_has_handles = true) {
    const Mesh tube = make_tube(180, 40, 0.05f, 0.4f);
    mesh = tube;
    const auto offset = static_cast<std::int32_t>(tube.vertex_count());
    for (std::size_t i = 0; i < tube.positions.size(); ++i) mesh.positions.push_back(tube.positions[i] + (i % 3 == 0 ? 1.0f : 0.0f));
    for (std::int32_t v : tube.triangles) mesh.triangles.push_back(v + offset);
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
      const float y = mesh.positions[3 * v + 1];
      const bool second = v >= tube.vertex_count();
      if ((y < 0.1f || y > 0.3f) && (second_has_handles || !second)) handles.push_back(static_cast<std::int32_t>(v));
    }
  }
  // Handle targets: the first tube's top sheared 5 cm along +X, the second's top lifted 3 cm
  // and twisted, both bottoms in place.
  Eigen::MatrixXd targets() const {
    Eigen::MatrixXd t(static_cast<Eigen::Index>(handles.size()), 3);
    for (std::size_t h = 0; h < handles.size(); ++h) {
      const auto v = static_cast<std::size_t>(handles[h]);
      Eigen::Vector3d p(mesh.positions[3 * v], mesh.positions[3 * v + 1], mesh.positions[3 * v + 2]);
      if (p.y() > 0.3) {
        if (p.x() < 0.5) {
          p.x() += 0.05;
        } else {
          const Eigen::Vector3d axis(1, 0, 0);
          p = axis + Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()) * (p - axis) + Eigen::Vector3d(0, 0.03, 0);
        }
      }
      t.row(static_cast<Eigen::Index>(h)) = p.transpose();
    }
    return t;
  }
};

double worst_difference(const std::vector<float>& a, const std::vector<float>& b) {
  double worst = 0;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, double(std::abs(a[i] - b[i])));
  return worst;
}

TEST(BandLaplacianDeformerPieces, SplitSolvesAgreeWithOneFactorisationOfTheWholeBand) {
  const TwoTubes c;
  const BandLaplacianDeformer whole(c.mesh, c.handles, false, BandSolver::DIRECT);
  const BandLaplacianDeformer automatic(c.mesh, c.handles);
  const BandLaplacianDeformer supernodal(c.mesh, c.handles, false, BandSolver::SUPERNODAL);
  ASSERT_TRUE(whole.ok() && automatic.ok() && supernodal.ok());
  ASSERT_GE(whole.free_vertices().size(), BAND_SUPERNODAL_UNKNOWNS);
  EXPECT_EQ(whole.pieces(), 1u);
  EXPECT_EQ(automatic.pieces(), 2u);
  EXPECT_EQ(supernodal.pieces(), 2u);
  const Eigen::MatrixXd delta = whole.laplacian_coordinates(c.mesh.positions);
  const Eigen::MatrixXd targets = c.targets();
  const std::vector<float> a = whole.deform(delta, targets);
  const std::vector<float> b = automatic.deform(delta, targets);
  const std::vector<float> s = supernodal.deform(delta, targets);
  ASSERT_EQ(a.size(), c.mesh.positions.size());
  // The pieces are independent systems, so splitting changes nothing but round-off: float
  // output rounding (~6e-8 m at 1 m) and the factorisations' own error, far below 1e-6 m.
  EXPECT_LT(worst_difference(a, b), 1e-6);
  EXPECT_LT(worst_difference(a, s), 1e-6);
  // The solve did something: the first tube's middle moved towards its sheared top.
  double moved = 0;
  for (std::int32_t v : whole.free_vertices()) moved = std::max(moved, double(std::abs(a[3 * std::size_t(v)] - c.mesh.positions[3 * std::size_t(v)])));
  EXPECT_GT(moved, 0.01);
}

TEST(BandLaplacianDeformerPieces, SmallBandsKeepOneFactorisation) {
  // One tube alone, 3,600 free vertices: below BAND_SUPERNODAL_UNKNOWNS, AUTO factors the
  // whole band once (the Table-1 garments' path).
  const Mesh tube = make_tube(180, 40, 0.05f, 0.4f);
  std::vector<std::int32_t> handles;
  for (std::size_t v = 0; v < tube.vertex_count(); ++v)
    if (tube.positions[3 * v + 1] < 0.1f || tube.positions[3 * v + 1] > 0.3f) handles.push_back(static_cast<std::int32_t>(v));
  const BandLaplacianDeformer deformer(tube, handles);
  ASSERT_TRUE(deformer.ok());
  EXPECT_LT(deformer.free_vertices().size(), BAND_SUPERNODAL_UNKNOWNS);
  EXPECT_EQ(deformer.pieces(), 1u);
  EXPECT_EQ(BandLaplacianDeformer(tube, handles, false, BandSolver::MULTIGRID).pieces(), 0u);
}

TEST(BandLaplacianDeformerPieces, APieceWithoutHandlesIsReported) {
  const TwoTubes c(false); // the second tube is all free: its piece is singular
  EXPECT_FALSE(BandLaplacianDeformer(c.mesh, c.handles).ok());
  EXPECT_FALSE(BandLaplacianDeformer(c.mesh, c.handles, false, BandSolver::SUPERNODAL).ok());
  EXPECT_FALSE(BandLaplacianDeformer(c.mesh, c.handles, false, BandSolver::DIRECT).ok());
}

} // namespace
} // namespace vfit
