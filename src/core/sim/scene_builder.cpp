#include "tescalib/core/sim/scene_builder.h"

#include <algorithm>
#include <cmath>

#include "tescalib/core/sim/simulator_random.h"

namespace tescalib {
namespace sim {
namespace {

using Vec3 = Eigen::Vector3f;

constexpr double kChunk = 60.0;  // m of road generated from one sub-seed

/// Everything one generator needs: the road, the output list and the chunk's random stream.
struct Builder {
  const RoadPath& road;           ///< places objects in road coordinates
  std::vector<Primitive>& prims;  ///< where they go
  SimRandom& rng;                 ///< the chunk's random stream

  float uni(double lo, double hi) { return static_cast<float>(rng.uniform(lo, hi)); }

  /// Colour from a palette with a few percent of per-object variation.
  Vec3 pick(std::initializer_list<Vec3> palette) {
    const int k = rng.uniformInt(0, static_cast<int>(palette.size()) - 1);
    const Vec3 base = *(palette.begin() + k);
    const float b = uni(0.9, 1.1);
    return Vec3(base.x() * b * uni(0.96, 1.04), base.y() * b * uni(0.96, 1.04),
                base.z() * b * uni(0.96, 1.04))
        .cwiseMin(1.f);
  }

  /// Adds a primitive centred at road coordinates (s, l), its local x axis turned `yaw` from the
  /// road direction.
  Primitive& add(Shape shape, Material material, double s, double l, float hx, float hy, float z0,
                 float z1, double yaw = 0.0) {
    Primitive p;
    p.shape = shape;
    p.material = material;
    p.style = rng.bits();
    const Eigen::Vector2d c = road.toWorld(s, l);
    p.cx = static_cast<float>(c.x());
    p.cy = static_cast<float>(c.y());
    const double th = road.heading(s) + yaw;
    p.cos_yaw = static_cast<float>(std::cos(th));
    p.sin_yaw = static_cast<float>(std::sin(th));
    p.hx = hx, p.hy = hy, p.z0 = z0, p.z1 = z1;
    prims.push_back(p);
    return prims.back();
  }
};

void setColor(float dst[3], const Vec3& c) { dst[0] = c.x(), dst[1] = c.y(), dst[2] = c.z(); }

const Vec3 kFoliageGreen(0.2f, 0.36f, 0.11f);

/// A parked car centred at (s, l); `yaw` relative to the road (0 = facing along it).
void addCar(Builder& b, double s, double l, double yaw) {
  const float length = b.uni(3.9, 4.8), width = b.uni(1.7, 1.85);
  const float body_top = 0.3f + b.uni(0.62, 0.78), cabin_h = b.uni(0.4, 0.52);
  const Vec3 paint = b.pick({{0.85f, 0.85f, 0.85f},
                             {0.6f, 0.61f, 0.63f},
                             {0.1f, 0.1f, 0.11f},
                             {0.3f, 0.31f, 0.33f},
                             {0.6f, 0.08f, 0.07f},
                             {0.12f, 0.2f, 0.5f},
                             {0.08f, 0.12f, 0.3f},
                             {0.15f, 0.3f, 0.18f},
                             {0.7f, 0.64f, 0.5f}});
  const uint32_t style = b.rng.bits();
  const double c = std::cos(yaw), sn = std::sin(yaw);
  // Offsets in the car frame -> road frame (s along, l across), small-angle exact for yaw 0/pi/2.
  auto at = [&](double dx, double dy, double* ss, double* ll) {
    *ss = s + c * dx - sn * dy;
    *ll = l + sn * dx + c * dy;
  };
  Primitive& body = b.add(Shape::kBox, Material::kCarBody, s, l, 0.5f * length, 0.5f * width, 0.3f,
                          body_top, yaw);
  body.style = style;
  body.param[0] = 1.f;
  setColor(body.color, paint);
  double ss, ll;
  const float cabin_len = 0.55f * length, back = b.uni(-0.15, 0.05) * length;
  at(back, 0.0, &ss, &ll);
  Primitive& cabin = b.add(Shape::kBox, Material::kCarCabin, ss, ll, 0.5f * cabin_len,
                           0.5f * width - 0.08f, body_top, body_top + cabin_h, yaw);
  cabin.style = style;
  setColor(cabin.color, paint);
  for (int i = -1; i <= 1; i += 2)
    for (int j = -1; j <= 1; j += 2) {
      at(i * (0.5 * length - 0.78), j * (0.5 * width - 0.1), &ss, &ll);
      b.add(Shape::kBox, Material::kTire, ss, ll, 0.32f, 0.11f, 0.f, 0.64f, yaw);
    }
}

/// A tree standing at (s, l).
void addTree(Builder& b, double s, double l, float scale) {
  const float trunk_h = b.uni(2.4, 3.4) * scale, r = b.uni(0.12, 0.2) * scale;
  Primitive& trunk =
      b.add(Shape::kCylinder, Material::kBark, s, l, r, r, 0.f, trunk_h + 0.6f, b.uni(0, 2 * M_PI));
  setColor(trunk.color, b.pick({{0.3f, 0.23f, 0.16f}, {0.36f, 0.32f, 0.27f}}));
  const float rh = b.uni(1.6, 2.3) * scale, rv = b.uni(1.8, 2.5) * scale;
  const Vec3 green = b.pick({kFoliageGreen, {0.26f, 0.38f, 0.12f}, {0.16f, 0.3f, 0.12f}});
  const uint32_t style = b.rng.bits();
  // A main crown with two smaller lobes, so it is not a ball on a stick.
  for (int k = 0; k < 3; ++k) {
    const float f = k == 0 ? 1.f : b.uni(0.55, 0.75);
    const double dir = b.uni(0, 2 * M_PI), off = k == 0 ? 0.0 : b.uni(0.45, 0.75) * rh;
    const float zc = trunk_h - 0.2f + rv + (k == 0 ? 0.f : b.uni(-0.5, 0.4) * rv);
    Primitive& crown = b.add(Shape::kEllipsoid, Material::kFoliage, s + off * std::cos(dir),
                             l + off * std::sin(dir), f * rh, f * rh * b.uni(0.85, 1.0),
                             zc - f * rv, zc + f * rv, b.uni(0, 2 * M_PI));
    crown.style = style;
    setColor(crown.color, green);
  }
}

/// Curb stones (2 m long) along one side of the road between stations s0 and s1.
void addCurb(Builder& b, double s0, double s1, double l, float height) {
  for (double s = s0; s + 1.0 <= s1; s += 2.0) {
    Primitive& c = b.add(Shape::kBox, Material::kCurb, s + 1.0, l, 1.f, 0.075f, 0.f, height);
    setColor(c.color, Vec3(0.6f, 0.6f, 0.58f));
  }
}

/// A street lamp at (s, l) with its arm over the road (side = +1 left, -1 right).
void addLamp(Builder& b, double s, double l, int side, float height) {
  Primitive& pole = b.add(Shape::kCylinder, Material::kMetal, s, l, 0.08f, 0.08f, 0.f, height);
  setColor(pole.color, Vec3(0.4f, 0.42f, 0.43f));
  Primitive& arm = b.add(Shape::kBox, Material::kMetal, s, l - side * 0.7, 0.05f, 0.7f,
                         height - 0.25f, height - 0.15f);
  setColor(arm.color, Vec3(0.4f, 0.42f, 0.43f));
  Primitive& head = b.add(Shape::kBox, Material::kMetal, s, l - side * 1.4, 0.18f, 0.3f,
                          height - 0.4f, height - 0.15f);
  setColor(head.color, Vec3(0.3f, 0.3f, 0.32f));
}

/// A traffic sign at (s, l), its face towards the approaching vehicle.
void addSign(Builder& b, double s, double l) {
  Primitive& pole = b.add(Shape::kCylinder, Material::kMetal, s, l, 0.035f, 0.035f, 0.f, 2.45f);
  setColor(pole.color, Vec3(0.55f, 0.56f, 0.57f));
  // Local x across the road, so the +y face looks back along the road.
  Primitive& plate =
      b.add(Shape::kBox, Material::kSign, s - 0.06, l, 0.32f, 0.02f, 1.8f, 2.44f, M_PI / 2);
  plate.param[0] = 1.f;
  setColor(plate.color, b.pick({{0.7f, 0.08f, 0.08f}, {0.1f, 0.25f, 0.65f}}));
}

// ---------------------------------------------------------------------------------------------
// Urban: a street canyon.

void urbanFacades(Builder& b, double s0, double s1, int side) {
  double cursor = s0;
  while (cursor < s1 - 1e-6) {
    const double remaining = s1 - cursor;
    double width = remaining < 14.0 ? remaining : b.uni(7.0, std::min(18.0, remaining - 7.0));
    if (width > 8.0 && b.rng.chance(0.15)) {  // an alley
      cursor += b.uni(3.0, 5.5);
      width = s1 - cursor < 14.0 ? s1 - cursor : std::min(width, s1 - cursor - 7.0);
      if (width < 3.0) break;
    }
    const float facade = b.uni(9.8, 10.8), depth = b.uni(12.0, 18.0);
    const int floors = b.rng.uniformInt(3, 7);
    const float floor_h = b.uni(3.0, 3.5);
    const float height = floor_h + 1.f + (floors - 1) * floor_h + b.uni(0.6, 1.2);
    const bool brick = b.rng.chance(0.4);
    Primitive& p = b.add(Shape::kBox, brick ? Material::kBrickFacade : Material::kPlasterFacade,
                         cursor + 0.5 * width, side * (facade + 0.5 * depth),
                         0.5f * static_cast<float>(width) + 0.2f, 0.5f * depth, 0.f, height);
    setColor(p.color, brick ? b.pick({{0.55f, 0.27f, 0.18f},
                                      {0.62f, 0.45f, 0.3f},
                                      {0.45f, 0.2f, 0.16f},
                                      {0.5f, 0.38f, 0.32f}})
                            : b.pick({{0.85f, 0.8f, 0.66f},
                                      {0.78f, 0.62f, 0.4f},
                                      {0.72f, 0.72f, 0.7f},
                                      {0.62f, 0.7f, 0.75f},
                                      {0.82f, 0.66f, 0.6f},
                                      {0.9f, 0.88f, 0.84f}}));
    setColor(p.color2, b.pick({{0.88f, 0.88f, 0.86f}, {0.3f, 0.3f, 0.3f}, {0.45f, 0.33f, 0.22f}}));
    p.param[0] = floor_h;
    p.param[1] = b.uni(1.0, 1.4);
    p.param[2] = b.uni(1.4, 1.8);
    p.param[3] = p.param[1] + b.uni(1.2, 2.0);
    cursor += width;
  }
  // The back row closes the view through alleys.
  for (double s = s0; s < s1 - 1e-6;) {
    const double w = std::min(b.uni(15.0, 25.0), float(s1 - s));
    Primitive& p = b.add(Shape::kBox, Material::kPlasterFacade, s + 0.5 * w, side * 36.0,
                         0.5f * float(w) + 0.2f, 8.f, 0.f, b.uni(12.0, 22.0));
    setColor(p.color, b.pick({{0.75f, 0.7f, 0.6f}, {0.6f, 0.6f, 0.62f}, {0.7f, 0.55f, 0.45f}}));
    setColor(p.color2, Vec3(0.85f, 0.85f, 0.83f));
    p.param[0] = 3.2f, p.param[1] = 1.2f, p.param[2] = 1.6f, p.param[3] = 3.f;
    s += w;
  }
}

void urbanChunk(Builder& b, double s0, double s1, int side) {
  urbanFacades(b, s0, s1, side);
  addCurb(b, s0, s1, side * 6.075, 0.13f);
  // Parked cars in the parking lane (|l| 3.5 .. 6).
  for (double s = s0 + b.uni(0.5, 3.0); s < s1 - 5.0;) {
    if (b.rng.chance(0.2)) {
      s += b.uni(5.0, 12.0);
      continue;
    }
    addCar(b, s + 2.5, side * b.uni(4.65, 4.85), side > 0 ? M_PI : 0.0);
    s += 5.0 + b.uni(0.6, 3.5);
  }
  for (double s = s0 + b.uni(2.0, 8.0); s < s1 - 1.0; s += b.uni(10.0, 16.0))
    if (b.rng.chance(0.75)) addTree(b, s, side * b.uni(7.3, 7.6), 1.f);
  if (b.rng.chance(0.8)) addLamp(b, b.uni(s0 + 2, s1 - 2), side * 6.45, side, 7.f);
  if (b.rng.chance(0.35)) addSign(b, b.uni(s0 + 2, s1 - 2), side * 6.6);
}

// ---------------------------------------------------------------------------------------------
// Residential: detached houses with gardens.

void residentialChunk(Builder& b, double s0, double s1, int side) {
  addCurb(b, s0, s1, side * 3.325, 0.12f);
  for (double s = s0 + b.uni(1.0, 8.0); s < s1 - 8.0;) {
    const float width = b.uni(8.0, 13.0);
    if (s + width > s1 - 0.5) break;
    const float depth = b.uni(8.0, 11.0), front = b.uni(12.0, 16.0);
    const int floors = b.rng.uniformInt(1, 2);
    const float floor_h = 2.8f, wall_h = floors * floor_h + 0.3f;
    const double sc = s + 0.5 * width, lc = side * (front + 0.5 * depth);
    Primitive& wall =
        b.add(Shape::kBox, Material::kHouseWall, sc, lc, 0.5f * width, 0.5f * depth, 0.f, wall_h);
    const Vec3 wall_c = b.pick({{0.9f, 0.88f, 0.84f},
                                {0.88f, 0.8f, 0.62f},
                                {0.93f, 0.88f, 0.7f},
                                {0.72f, 0.74f, 0.75f},
                                {0.66f, 0.75f, 0.82f},
                                {0.85f, 0.62f, 0.52f}});
    setColor(wall.color, wall_c);
    setColor(wall.color2, Vec3(0.92f, 0.92f, 0.9f));
    wall.param[0] = floor_h, wall.param[1] = 1.2f, wall.param[2] = 1.3f;
    wall.param[3] = b.uni(2.6, 3.4);
    Primitive& roof = b.add(Shape::kGable, Material::kTileRoof, sc, lc, 0.5f * width + 0.4f,
                            0.5f * depth + 0.5f, wall_h, wall_h + b.uni(2.2, 3.4));
    setColor(roof.color,
             b.pick({{0.55f, 0.24f, 0.14f}, {0.4f, 0.26f, 0.2f}, {0.25f, 0.25f, 0.28f}}));
    setColor(roof.color2, wall_c);
    const double drive = s + width + 1.8;
    if (b.rng.chance(0.45) && drive + 2.0 < s1) {  // garage with a car in the driveway
      Primitive& garage = b.add(Shape::kBox, Material::kPlasterFacade, drive + 0.4,
                                side * (front + 3.5), 1.8f, 3.f, 0.f, 2.6f);
      setColor(garage.color, wall_c * 0.95f);
      setColor(garage.color2, Vec3(0.8f, 0.8f, 0.8f));
      garage.param[0] = 2.6f;
      garage.param[3] = 10.f;  // window pitch wider than the garage: no windows
      addCar(b, drive + 0.4, side * (front - 2.6), M_PI / 2);
    }
    // Front boundary: hedge or fence, with a gap for the path.
    const double lf = side * b.uni(7.5, 7.9);
    if (b.rng.chance(0.5)) {
      Primitive& hedge = b.add(Shape::kBox, Material::kHedge, s + 0.35 * width, lf,
                               0.35f * width - 0.6f, 0.4f, 0.f, b.uni(0.9, 1.6));
      setColor(hedge.color, kFoliageGreen * b.uni(0.8, 1.1));
    } else if (b.rng.chance(0.6)) {
      Primitive& fence = b.add(Shape::kBox, Material::kFence, s + 0.35 * width, lf,
                               0.35f * width - 0.6f, 0.03f, 0.f, 1.0f);
      setColor(fence.color, b.pick({{0.85f, 0.85f, 0.82f}, {0.5f, 0.36f, 0.22f}}));
    }
    const int trees = b.rng.uniformInt(0, 2);
    for (int t = 0; t < trees; ++t)
      addTree(b, s + b.uni(0.0, width), side * b.uni(9.5, 11.0), b.uni(0.9, 1.4));
    for (int k = b.rng.uniformInt(0, 3); k > 0; --k) {
      const float r = b.uni(0.5, 1.1);
      Primitive& bush = b.add(Shape::kEllipsoid, Material::kFoliage, s + b.uni(0.0, width),
                              side * (front - b.uni(0.8, 1.5)), r, r, -0.2f, 1.6f * r);
      setColor(bush.color, kFoliageGreen * b.uni(0.8, 1.2));
    }
    // Trees behind the houses.
    if (b.rng.chance(0.6))
      addTree(b, s + b.uni(0.0, width), side * (front + depth + b.uni(4.0, 10.0)), b.uni(1.2, 1.6));
    s += width + b.uni(5.0, 14.0);
  }
  for (double s = s0 + b.uni(3.0, 12.0); s < s1 - 1.0; s += b.uni(12.0, 20.0))
    if (b.rng.chance(0.5)) addTree(b, s, side * 4.3, 1.f);
  if (side > 0 && b.rng.chance(0.35)) addCar(b, b.uni(s0 + 4, s1 - 4), 2.2, M_PI);
  if (b.rng.chance(0.4)) addLamp(b, b.uni(s0 + 2, s1 - 2), side * 4.6, side, 5.5f);
}

// ---------------------------------------------------------------------------------------------
// Highway: guard rails and open land.

void guardRail(Builder& b, double s0, double s1, double l, int facing) {
  for (double s = s0; s + 2.0 <= s1; s += 4.0) {
    Primitive& rail =
        b.add(Shape::kBox, Material::kGuardRail, s + 2.0, l, 2.f, 0.03f, 0.45f, 0.78f);
    setColor(rail.color, Vec3(0.62f, 0.64f, 0.65f));
    for (int k = 0; k < 2; ++k) {
      Primitive& post = b.add(Shape::kBox, Material::kConcrete, s + 1.0 + 2.0 * k, l - facing * 0.1,
                              0.05f, 0.06f, 0.f, 0.72f);
      setColor(post.color, Vec3(0.5f, 0.51f, 0.5f));
    }
  }
}

void highwayChunk(Builder& b, double s0, double s1, int side) {
  guardRail(b, s0, s1, side * 14.6, side);
  guardRail(b, s0, s1, side * 0.25, -side);
  // Delineator posts every 50 m (below 1.1 m) and sparse trees far from the road.
  for (double s = std::ceil(s0 / 50.0) * 50.0; s < s1; s += 50.0) {
    Primitive& d =
        b.add(Shape::kBox, Material::kConcrete, s, side * 15.3, 0.06f, 0.06f, 0.f, 1.05f);
    setColor(d.color, Vec3(0.85f, 0.85f, 0.83f));
  }
  for (int k = b.rng.uniformInt(0, 2); k > 0; --k)
    addTree(b, b.uni(s0, s1), side * b.uni(28.0, 70.0), b.uni(1.0, 1.5));
  for (int k = b.rng.uniformInt(0, 3); k > 0; --k) {
    const float r = b.uni(0.8, 1.6);
    Primitive& bush = b.add(Shape::kEllipsoid, Material::kFoliage, b.uni(s0, s1),
                            side * b.uni(20.0, 60.0), r, r, -0.3f, 1.4f * r);
    setColor(bush.color, kFoliageGreen * b.uni(0.8, 1.2));
  }
  // A distant tree line for the cameras, beyond the LiDAR's range.
  for (double s = s0 + b.uni(0.0, 6.0); s < s1; s += b.uni(6.0, 11.0)) {
    const float r = b.uni(4.0, 7.0);
    Primitive& t = b.add(Shape::kEllipsoid, Material::kFoliage, s, side * b.uni(142.0, 160.0), r, r,
                         -1.f, b.uni(9.0, 16.0));
    setColor(t.color, kFoliageGreen * b.uni(0.7, 1.1));
  }
}

GroundLayout groundLayout(Scenario scenario) {
  GroundLayout g;
  using S = GroundSurface;
  switch (scenario) {
    case Scenario::kUrban:
      g.bands = {{-6.f, 6.f, S::kAsphalt},
                 {6.f, 10.5f, S::kPaving},
                 {-10.5f, -6.f, S::kPaving},
                 {10.5f, 70.f, S::kCobble},
                 {-70.f, -10.5f, S::kCobble}};
      g.markings = {{0.f, 0.12f, 3.f, 6.f}, {3.5f, 0.12f, 0.f, 0.f}, {-3.5f, 0.12f, 0.f, 0.f}};
      g.outside = S::kCobble;
      break;
    case Scenario::kResidential:
      g.bands = {{-3.4f, 3.4f, S::kAsphalt}, {3.4f, 5.2f, S::kGrass},   {-5.2f, -3.4f, S::kGrass},
                 {5.2f, 7.f, S::kPaving},    {-7.f, -5.2f, S::kPaving}, {7.f, 70.f, S::kGrass},
                 {-70.f, -7.f, S::kGrass}};
      g.markings = {{0.f, 0.1f, 3.f, 9.f}};
      g.outside = S::kField;
      break;
    case Scenario::kHighway:
      g.bands = {{0.4f, 14.f, S::kAsphalt}, {-14.f, -0.4f, S::kAsphalt}, {-0.4f, 0.4f, S::kGrass},
                 {14.f, 15.6f, S::kGravel}, {-15.6f, -14.f, S::kGravel}, {15.6f, 70.f, S::kGrass},
                 {-70.f, -15.6f, S::kGrass}};
      for (int side = -1; side <= 1; side += 2) {
        g.markings.push_back({side * 0.65f, 0.15f, 0.f, 0.f});
        g.markings.push_back({side * 4.1f, 0.15f, 6.f, 12.f});
        g.markings.push_back({side * 7.7f, 0.15f, 6.f, 12.f});
        g.markings.push_back({side * 11.3f, 0.25f, 0.f, 0.f});
      }
      g.outside = S::kField;
      break;
  }
  return g;
}

}  // namespace

std::string scenarioName(Scenario s) {
  switch (s) {
    case Scenario::kUrban:
      return "urban";
    case Scenario::kResidential:
      return "residential";
    case Scenario::kHighway:
      return "highway";
  }
  return "unknown";
}

bool parseScenario(const std::string& name, Scenario* s) {
  for (Scenario c : {Scenario::kUrban, Scenario::kResidential, Scenario::kHighway})
    if (name == scenarioName(c)) {
      *s = c;
      return true;
    }
  return false;
}

SceneWorld buildScene(Scenario scenario, uint64_t seed, double s_min, double s_max) {
  SceneWorld w;
  w.scenario = scenario;
  SimRandom global(subSeed(seed, 0x5ce9e));
  RoadCurves curves;
  // Gentle curves: minimum radius about 240 m in town, 1.5 km on the highway.
  const double amp_scale = scenario == Scenario::kHighway ? 0.2 : 1.0;
  const double len_scale = scenario == Scenario::kHighway ? 2.5 : 1.0;
  curves.amplitude[0] = amp_scale * global.uniform(0.08, 0.15);
  curves.amplitude[1] = amp_scale * global.uniform(0.02, 0.06);
  curves.length[0] = len_scale * global.uniform(380.0, 520.0);
  curves.length[1] = len_scale * global.uniform(160.0, 220.0);
  curves.phase[0] = global.uniform(0.0, 2 * M_PI);
  curves.phase[1] = global.uniform(0.0, 2 * M_PI);
  w.road = std::make_unique<RoadPath>(curves, s_min - 20.0, s_max + 20.0);
  w.ground = groundLayout(scenario);
  // Sun 25-60 deg off the road's mean direction (x): diagonal shadows, part of the street lit.
  const double sun_el = global.uniform(40.0, 60.0) * M_PI / 180.0;
  const double sun_off = global.uniform(25.0, 60.0) * M_PI / 180.0;
  const double sun_az =
      (global.chance(0.5) ? 0.0 : M_PI) + (global.chance(0.5) ? sun_off : -sun_off);
  w.sun = Vec3(static_cast<float>(std::cos(sun_el) * std::cos(sun_az)),
               static_cast<float>(std::cos(sun_el) * std::sin(sun_az)),
               static_cast<float>(std::sin(sun_el)));
  w.texture_seed = global.bits();
  w.lane_offset = scenario == Scenario::kUrban         ? -1.75f
                  : scenario == Scenario::kResidential ? -1.6f
                                                       : -5.9f;
  const int k0 = static_cast<int>(std::floor(s_min / kChunk));
  const int k1 = static_cast<int>(std::floor(s_max / kChunk));
  for (int k = k0; k <= k1; ++k) {
    for (int side = -1; side <= 1; side += 2) {
      SimRandom rng(subSeed(
          seed, (static_cast<uint64_t>(static_cast<uint32_t>(k)) << 8) | (side > 0 ? 1u : 2u)));
      Builder b{*w.road, w.prims, rng};
      const double s0 = k * kChunk, s1 = s0 + kChunk;
      switch (scenario) {
        case Scenario::kUrban:
          urbanChunk(b, s0, s1, side);
          break;
        case Scenario::kResidential:
          residentialChunk(b, s0, s1, side);
          break;
        case Scenario::kHighway:
          highwayChunk(b, s0, s1, side);
          break;
      }
    }
  }
  return w;
}

}  // namespace sim
}  // namespace tescalib
