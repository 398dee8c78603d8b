#include "tescalib/core/sim/scene_material.h"

#include <algorithm>
#include <cmath>

#include "tescalib/core/sim/scene_texture.h"

namespace tescalib {
namespace sim {
namespace {

using Vec3 = Eigen::Vector3f;

Vec3 rgb(const float c[3]) { return Vec3(c[0], c[1], c[2]); }

/// Texture frame of a box face: u runs to the right as seen from outside, v upwards from the
/// bottom (top and bottom faces: local x and y).
struct FaceFrame {
  float u = 0.f, v = 0.f;           ///< coordinates on the face (m)
  float width = 0.f, height = 0.f;  ///< face size (m)
  float fu = 0.f, fv = 0.f;         ///< pixel footprint along u and v (m)
};

FaceFrame faceFrame(const Primitive& p, const SurfacePoint& sp) {
  FaceFrame f;
  const Vec3& l = sp.local;
  Vec3 u_local = Vec3::UnitX(), v_local = Vec3::UnitZ();
  f.v = l.z() - p.z0;
  f.height = p.z1 - p.z0;
  switch (sp.face) {
    case kFacePosX:
      f.u = l.y() + p.hy, f.width = 2 * p.hy, u_local = Vec3::UnitY();
      break;
    case kFaceNegX:
      f.u = p.hy - l.y(), f.width = 2 * p.hy, u_local = -Vec3::UnitY();
      break;
    case kFacePosY:
      f.u = p.hx - l.x(), f.width = 2 * p.hx, u_local = -Vec3::UnitX();
      break;
    case kFaceNegY:
      f.u = l.x() + p.hx, f.width = 2 * p.hx;
      break;
    default:  // top, bottom
      f.u = l.x() + p.hx, f.v = l.y() + p.hy, f.width = 2 * p.hx, f.height = 2 * p.hy;
      v_local = Vec3::UnitY();
      break;
  }
  f.fu = sp.footprintAlong(localDirToWorld(p, u_local));
  f.fv = sp.footprintAlong(localDirToWorld(p, v_local));
  return f;
}

bool isSide(const SurfacePoint& sp) { return sp.face <= kFaceNegY; }

/// Windows of a facade (param: floor height, window width, window height, column pitch), drawn
/// over the wall albedo. Facades of shop streets get a taller ground floor with shop windows.
Vec3 withWindows(const Primitive& p, const FaceFrame& f, const Vec3& wall, float* refl) {
  const float floor_h = p.param[0], ww = p.param[1], wh = p.param[2], pitch = p.param[3];
  if (floor_h <= 0.f || f.width < pitch) return wall;
  const bool shops = p.material != Material::kHouseWall;
  const float ground_h = shops ? floor_h + 1.0f : 0.f;
  const int ncols = std::max(1, static_cast<int>((f.width - 0.8f) / pitch));
  const float margin = 0.5f * (f.width - ncols * pitch);
  const int col = static_cast<int>(std::floor((f.u - margin) / pitch));
  if (col < 0 || col >= ncols) return wall;
  const float uc = f.u - margin - (col + 0.5f) * pitch;
  int row;
  float vc, wwr = ww, whr = wh;
  if (f.v < ground_h) {  // shop windows
    row = -1;
    wwr = std::min(pitch - 0.4f, 2.f * ww);
    whr = ground_h - 1.4f;
    vc = f.v - (0.5f + 0.5f * whr);
  } else {
    row = static_cast<int>(std::floor((f.v - ground_h) / floor_h));
    const float centre = ground_h + row * floor_h + 0.55f * floor_h;
    if (centre + 0.5f * wh > f.height - 0.5f) return wall;  // parapet / eaves
    vc = f.v - centre;
  }
  const float cw =
      boxBand(uc, -0.5f * wwr, 0.5f * wwr, f.fu) * boxBand(vc, -0.5f * whr, 0.5f * whr, f.fv);
  const float sill = row < 0 ? 0.f
                             : boxBand(uc, -0.5f * wwr - 0.08f, 0.5f * wwr + 0.08f, f.fu) *
                                   boxBand(vc, -0.5f * whr - 0.12f, -0.5f * whr, f.fv);
  if (cw <= 0.f && sill <= 0.f) return wall;
  const float fr = 0.07f;
  const float inner = boxBand(uc, -0.5f * wwr + fr, 0.5f * wwr - fr, f.fu) *
                      boxBand(vc, -0.5f * whr + fr, 0.5f * whr - fr, f.fv);
  const float bars = clamp01(boxBand(uc, -0.035f, 0.035f, f.fu) +
                             boxBand(vc, 0.2f * whr - 0.035f, 0.2f * whr + 0.035f, f.fv));
  const float r = cellRandom(col, row, p.style);
  Vec3 glass;
  if (r < 0.3f) {  // curtains: pale cloth with folds
    const float folds = 0.85f + 0.15f * boxPulse(uc, 0.12f, 0.06f, f.fu);
    glass = Vec3(0.62f, 0.57f, 0.48f) * (0.8f + 0.6f * r) * folds;
  } else {  // dark glass, brighter towards the top where it reflects the sky
    const float sky = clamp01(vc / whr + 0.5f);
    glass = Vec3(0.07f, 0.09f, 0.12f) * (0.7f + 0.6f * r) * (1.f + 1.2f * sky);
  }
  const float fp = std::max(f.fu, f.fv);
  glass *= 1.f + 0.15f * fractalNoise(uc, vc, 0.3f, 3, 0.7f, fp, p.style + 11u);
  const float glass_w = inner * (1.f - bars);
  const float frame_w = std::max(cw - glass_w, 0.f) + sill;
  const float wall_w = std::max(1.f - cw - sill, 0.f);
  *refl = *refl * wall_w + 0.5f * frame_w + 0.05f * glass_w;
  return wall * wall_w + rgb(p.color2) * frame_w + glass * glass_w;
}

SurfaceLook brickFacade(const Primitive& p, const FaceFrame& f, float fp) {
  const int row = static_cast<int>(std::floor(f.v / 0.075f));
  const float uu = f.u + ((row & 1) ? 0.125f : 0.f);
  const float brick = boxPulse(uu, 0.25f, 0.235f, f.fu) * boxPulse(f.v, 0.075f, 0.062f, f.fv);
  const float resolved = lodWeight(0.25f, std::max(f.fu, 3.f * f.fv));
  const float rb = cellRandom(static_cast<int>(std::floor(uu / 0.25f)), row, p.style) - 0.5f;
  const Vec3 brick_c = rgb(p.color) * (1.f + 0.45f * rb * resolved);
  const Vec3 mortar(0.66f, 0.64f, 0.6f);
  Vec3 c = mortar * (1.f - brick) + brick_c * brick;
  c *= 1.f + 0.16f * fractalNoise(f.u, f.v, 0.6f, 6, 0.7f, fp, p.style) +
       0.08f * valueNoise(f.u * 0.6f, f.v * 0.12f, p.style + 7u);
  SurfaceLook out;
  out.reflectivity = 0.3f;
  out.albedo = withWindows(p, f, c, &out.reflectivity);
  return out;
}

SurfaceLook plasterFacade(const Primitive& p, const FaceFrame& f, float fp) {
  Vec3 c = rgb(p.color) * (1.f + 0.08f * fractalNoise(f.u, f.v, 2.f, 4, 0.6f, fp, p.style) +
                           0.12f * fractalNoise(f.u, f.v, 0.12f, 4, 0.8f, fp, p.style + 3u) +
                           0.06f * valueNoise(f.u * 0.5f, f.v * 0.1f, p.style + 5u));
  // Cornices at the floor lines and a stone base.
  const float ground_h = p.param[0] + 1.f;
  const float cornice = f.v > ground_h - 0.3f && p.param[0] > 0.f
                            ? boxPulse(f.v - ground_h + 0.3f, p.param[0], 0.3f, f.fv)
                            : boxBand(f.v, -1.f, 0.7f, f.fv);
  c = c * (1.f - cornice) + rgb(p.color2) * 0.9f * cornice;
  SurfaceLook out;
  out.reflectivity = 0.45f;
  out.albedo = withWindows(p, f, c, &out.reflectivity);
  return out;
}

SurfaceLook houseWall(const Primitive& p, const FaceFrame& f, float fp) {
  const float groove = 1.f - boxPulse(f.v, 0.18f, 0.163f, f.fv);
  Vec3 c = rgb(p.color) * (1.f - 0.45f * groove) *
           (1.f +
            0.07f * fractalNoise(f.u * 0.25f, f.v, 0.08f, 3, 0.7f, std::max(0.25f * f.fu, f.fv),
                                 p.style) +
            0.06f * fractalNoise(f.u, f.v, 1.5f, 5, 0.7f, fp, p.style + 9u));
  SurfaceLook out;
  out.reflectivity = 0.4f;
  out.albedo = withWindows(p, f, c, &out.reflectivity);
  return out;
}

SurfaceLook gravelRoof(const SurfacePoint& sp, const Vec3& base, uint32_t seed, float fp) {
  SurfaceLook out;
  out.albedo =
      base * (1.f + 0.25f * fractalNoise(sp.world.x(), sp.world.y(), 0.8f, 6, 0.8f, fp, seed));
  out.reflectivity = 0.2f;
  return out;
}

SurfaceLook tileRoof(const Primitive& p, const SurfacePoint& sp, float fp) {
  SurfaceLook out;
  if (sp.face == kFacePosX || sp.face == kFaceNegX) {  // gable end: wall boards
    const FaceFrame f = faceFrame(p, sp);
    const float groove = 1.f - boxPulse(f.v, 0.18f, 0.163f, f.fv);
    out.albedo = rgb(p.color2) * (1.f - 0.45f * groove) *
                 (1.f + 0.06f * fractalNoise(f.u, f.v, 1.f, 5, 0.7f, fp, p.style));
    out.reflectivity = 0.4f;
    return out;
  }
  const float fz = sp.footprintAlong(Vec3::UnitZ());
  const float fx = sp.footprintAlong(localDirToWorld(p, Vec3::UnitX()));
  const float z = sp.local.z() - p.z0;
  const int row = static_cast<int>(std::floor(z / 0.1f));
  const float x = sp.local.x() + ((row & 1) ? 0.11f : 0.f);
  const float tile = boxPulse(z, 0.1f, 0.082f, fz) * boxPulse(x, 0.22f, 0.205f, fx);
  const float resolved = lodWeight(0.22f, std::max(fx, 2.f * fz));
  const float rt = cellRandom(static_cast<int>(std::floor(x / 0.22f)), row, p.style) - 0.5f;
  const Vec3 c = rgb(p.color) * (1.f + 0.4f * rt * resolved);
  out.albedo = (c * tile + c * 0.45f * (1.f - tile)) *
               (1.f + 0.1f * fractalNoise(sp.local.x(), z, 0.5f, 5, 0.7f, fp, p.style + 1u));
  out.reflectivity = 0.2f;
  return out;
}

SurfaceLook carBody(const Primitive& p, const SurfacePoint& sp, float fp) {
  const FaceFrame f = faceFrame(p, sp);
  const Vec3 paint = rgb(p.color);
  // Blurred reflections of the surroundings and a little dust (view-independent).
  Vec3 c = paint * (1.f + 0.12f * fractalNoise(f.u, f.v, 0.8f, 3, 0.6f, fp, p.style) +
                    0.06f * fractalNoise(f.u, f.v, 0.06f, 3, 0.8f, fp, p.style + 5u));
  c += Vec3::Constant(0.04f) * clamp01(valueNoise(f.u * 1.5f, f.v * 4.f, p.style + 6u) + 0.2f);
  float refl = 0.25f + 0.3f * paint.mean();
  if (isSide(sp)) {
    const bool front_back =
        (sp.face == kFacePosX || sp.face == kFaceNegX);  // car length is along local x
    if (front_back) {
      const bool front = (sp.face == kFacePosX) == (p.param[0] > 0.f);
      const float bumper = boxBand(f.v, -1.f, 0.2f, f.fv);
      const float lights = (boxBand(f.u, 0.08f, 0.42f, f.fu) +
                            boxBand(f.u, f.width - 0.42f, f.width - 0.08f, f.fu)) *
                           boxBand(f.v, f.height - 0.22f, f.height - 0.06f, f.fv);
      const float plate = boxBand(f.u, 0.5f * f.width - 0.26f, 0.5f * f.width + 0.26f, f.fu) *
                          boxBand(f.v, 0.24f, 0.36f, f.fv);
      const Vec3 light_c = front ? Vec3(0.85f, 0.85f, 0.8f) : Vec3(0.7f, 0.06f, 0.05f);
      const float chars =
          0.5f + 0.5f * boxPulse(f.u, 0.055f, 0.03f, f.fu) * boxBand(f.v, 0.265f, 0.335f, f.fv);
      c = c * (1.f - bumper - lights - plate) + Vec3(0.08f, 0.08f, 0.09f) * bumper +
          light_c * lights + Vec3(0.9f, 0.9f, 0.88f) * (1.f - 0.85f * chars) * plate;
      refl = refl * (1.f - plate - lights) + 0.95f * plate + 0.6f * lights;
    } else {
      const float seams = boxBand(f.u, 0.3f * f.width, 0.3f * f.width + 0.012f, f.fu) +
                          boxBand(f.u, 0.56f * f.width, 0.56f * f.width + 0.012f, f.fu);
      const float handles = (boxBand(f.u, 0.36f * f.width, 0.36f * f.width + 0.15f, f.fu) +
                             boxBand(f.u, 0.62f * f.width, 0.62f * f.width + 0.15f, f.fu)) *
                            boxBand(f.v, f.height - 0.2f, f.height - 0.16f, f.fv);
      const float rocker = boxBand(f.v, -1.f, 0.1f, f.fv);
      c = c * (1.f - 0.6f * seams - 0.3f * handles) * (1.f - 0.75f * rocker);
    }
    // Road dirt near the bottom.
    c *= 1.f - 0.2f * clamp01(1.f - f.v / 0.35f) *
                   (0.6f + 0.4f * valueNoise(f.u * 6.f, f.v * 6.f, p.style + 2u));
  }
  SurfaceLook out;
  out.albedo = c;
  out.reflectivity = refl;
  return out;
}

SurfaceLook carCabin(const Primitive& p, const SurfacePoint& sp, float fp) {
  const FaceFrame f = faceFrame(p, sp);
  SurfaceLook out;
  const Vec3 paint = rgb(p.color);
  if (!isSide(sp)) {
    out.albedo = paint * (1.f + 0.04f * fractalNoise(f.u, f.v, 0.5f, 4, 0.7f, fp, p.style));
    out.reflectivity = 0.25f + 0.3f * paint.mean();
    return out;
  }
  const bool ends = (sp.face == kFacePosX || sp.face == kFaceNegX);
  const float edge_u = ends ? 0.1f : 0.06f;
  float glass =
      boxBand(f.u, edge_u, f.width - edge_u, f.fu) * boxBand(f.v, 0.05f, f.height - 0.05f, f.fv);
  if (!ends) glass *= 1.f - boxBand(f.u, 0.5f * f.width - 0.06f, 0.5f * f.width + 0.06f, f.fu);
  const float sky = clamp01(f.v / f.height);
  Vec3 g = Vec3(0.05f, 0.06f, 0.07f) * (1.f + 2.f * sky * sky) *
           (1.f + 0.2f * fractalNoise(f.u, f.v, 0.25f, 3, 0.7f, fp, p.style + 4u));
  out.albedo = paint * (1.f - glass) + g * glass;
  out.reflectivity = (0.25f + 0.3f * paint.mean()) * (1.f - glass) + 0.05f * glass;
  return out;
}

SurfaceLook tire(const Primitive& p, const SurfacePoint& sp, float fp) {
  const FaceFrame f = faceFrame(p, sp);
  SurfaceLook out;
  Vec3 c =
      Vec3::Constant(0.05f) * (1.f + 0.3f * fractalNoise(f.u, f.v, 0.1f, 3, 0.7f, fp, p.style));
  if (sp.face == kFacePosY || sp.face == kFaceNegY) {
    const float d = std::hypot(f.u - 0.5f * f.width, f.v - 0.5f * f.height);
    const float fd = std::max(f.fu, f.fv);
    const float rim = boxBand(d, 0.05f, 0.19f, fd);
    const float hub = boxBand(d, -1.f, 0.04f, fd);
    c = c * (1.f - rim - hub) + Vec3(0.55f, 0.56f, 0.58f) * rim + Vec3(0.25f, 0.25f, 0.26f) * hub;
  }
  out.albedo = c;
  out.reflectivity = 0.05f;
  return out;
}

SurfaceLook bark(const Primitive& p, const SurfacePoint& sp, float fp) {
  const Vec3& l = sp.local;
  SurfaceLook out;
  out.albedo = rgb(p.color) * (1.f + 0.35f * fractalNoise(l.x() * 4.f, l.y() * 4.f, l.z() * 0.5f,
                                                          0.4f, 4, 0.7f, 4.f * fp, p.style));
  out.reflectivity = 0.25f;
  return out;
}

SurfaceLook foliage(const Primitive& p, const SurfacePoint& sp, float fp, float wavelength) {
  const Vec3& w = sp.world;
  const float n = fractalNoise(w.x(), w.y(), w.z(), wavelength, 5, 0.8f, fp, p.style);
  const float holes = clamp01((n + 0.9f) * 2.f);  // gaps between leaf clusters
  SurfaceLook out;
  out.albedo = rgb(p.color) * std::max(0.7f + 0.45f * n, 0.25f) * (0.35f + 0.65f * holes);
  out.reflectivity = 0.3f;
  return out;
}

SurfaceLook noisy3d(const Primitive& p, const SurfacePoint& sp, float fp, float amplitude,
                    float refl) {
  const Vec3& l = sp.local;
  SurfaceLook out;
  out.albedo = rgb(p.color) *
               (1.f + amplitude * fractalNoise(l.x(), l.y(), l.z(), 0.5f, 5, 0.75f, fp, p.style));
  out.reflectivity = refl;
  return out;
}

SurfaceLook curb(const Primitive& p, const SurfacePoint& sp, float fp) {
  const Vec3& w = sp.world;
  SurfaceLook out;
  out.albedo =
      rgb(p.color) * (1.f + 0.18f * fractalNoise(w.x(), w.y(), w.z(), 0.2f, 4, 0.8f, fp, p.style));
  out.reflectivity = 0.35f;
  return out;
}

SurfaceLook sign(const Primitive& p, const SurfacePoint& sp, float fp) {
  const FaceFrame f = faceFrame(p, sp);
  const bool front = (sp.face == kFacePosY) == (p.param[0] > 0.f);
  SurfaceLook out;
  if (!(sp.face == kFacePosY || sp.face == kFaceNegY) || !front) {
    out.albedo = Vec3::Constant(0.45f);
    out.reflectivity = 0.3f;
    return out;
  }
  const float inside =
      boxBand(f.u, 0.05f, f.width - 0.05f, f.fu) * boxBand(f.v, 0.05f, f.height - 0.05f, f.fv);
  const float bar = boxBand(f.u, 0.2f * f.width, 0.8f * f.width, f.fu) *
                    boxBand(f.v, 0.42f * f.height, 0.58f * f.height, f.fv);
  const Vec3 white(0.9f, 0.9f, 0.9f);
  out.albedo = (white * (1.f - inside) + rgb(p.color) * (inside - bar) + white * bar) *
               (1.f + 0.05f * fractalNoise(f.u, f.v, 0.2f, 3, 0.7f, fp, p.style));
  out.reflectivity = 0.9f;
  return out;
}

SurfaceLook guardRail(const Primitive& p, const SurfacePoint& sp, float fp) {
  const FaceFrame f = faceFrame(p, sp);
  const float profile = 0.3f * std::cos(2.f * float(M_PI) * f.v / 0.16f) * lodWeight(0.16f, f.fv);
  const float rust = clamp01(valueNoise(f.u * 1.5f, f.v * 3.f, p.style + 3u) - 0.45f);
  SurfaceLook out;
  out.albedo = rgb(p.color) * (0.85f + profile) *
               (1.f + 0.1f * fractalNoise(f.u, f.v, 0.4f, 5, 0.75f, fp, p.style)) *
               (1.f - 0.6f * rust);
  out.reflectivity = 0.5f;
  return out;
}

SurfaceLook fence(const Primitive& p, const SurfacePoint& sp, float fp) {
  const FaceFrame f = faceFrame(p, sp);
  const float slat = isSide(sp) ? boxPulse(f.u, 0.14f, 0.1f, f.fu) : 1.f;
  SurfaceLook out;
  out.albedo =
      rgb(p.color) * (0.35f + 0.65f * slat) *
      (1.f + 0.15f * fractalNoise(f.u * 3.f, f.v * 0.3f, 0.3f, 4, 0.7f, 3.f * fp, p.style));
  out.reflectivity = 0.3f;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Ground

struct GroundCoords {
  float x, y;    ///< world (m)
  float s, l;    ///< road frame (m); valid when on_road
  float fs, fl;  ///< footprint along the road and across it (m)
  float fp;      ///< isotropic footprint (m)
};

SurfaceLook groundSurface(GroundSurface surface, const GroundCoords& g, uint32_t seed,
                          float asphalt_texture) {
  SurfaceLook out;
  switch (surface) {
    case GroundSurface::kAsphalt: {
      // Patches, then grain down to the aggregate (1 cm).
      const float n =
          asphalt_texture * (0.08f * fractalNoise(g.x, g.y, 4.f, 2, 0.5f, g.fp, seed) +
                             0.2f * fractalNoise(g.x, g.y, 0.2f, 3, 0.85f, g.fp, seed + 1u) +
                             0.22f * fractalNoise(g.x, g.y, 0.025f, 2, 0.9f, g.fp, seed + 13u));
      out.albedo = Vec3(0.27f, 0.27f, 0.285f) * (1.f + n);
      out.reflectivity = 0.12f + 0.05f * n;
      break;
    }
    case GroundSurface::kPaving: {
      const float tile = boxPulse(g.s, 0.4f, 0.39f, g.fs) * boxPulse(g.l, 0.4f, 0.39f, g.fl);
      const float resolved = lodWeight(0.4f, std::max(g.fs, g.fl));
      const float rt = cellRandom(static_cast<int>(std::floor(g.s / 0.4f)),
                                  static_cast<int>(std::floor(g.l / 0.4f)), seed + 2u) -
                       0.5f;
      const Vec3 c = Vec3(0.56f, 0.55f, 0.53f) * (1.f + 0.25f * rt * resolved);
      out.albedo = (c * tile + c * 0.6f * (1.f - tile)) *
                   (1.f + 0.12f * fractalNoise(g.x, g.y, 0.3f, 4, 0.8f, g.fp, seed + 3u));
      out.reflectivity = 0.3f;
      break;
    }
    case GroundSurface::kGrass: {
      const float patches = fractalNoise(g.x, g.y, 5.f, 2, 0.5f, g.fp, seed + 4u);
      const float blades = fractalNoise(g.x, g.y, 0.25f, 4, 0.85f, g.fp, seed + 5u);
      out.albedo =
          Vec3(0.2f + 0.06f * patches, 0.33f + 0.04f * patches, 0.1f) * (1.f + 0.35f * blades);
      out.reflectivity = 0.35f;
      break;
    }
    case GroundSurface::kGravel: {
      const float n = fractalNoise(g.x, g.y, 0.15f, 4, 0.9f, g.fp, seed + 6u);
      out.albedo = Vec3(0.45f, 0.42f, 0.38f) * (1.f + 0.3f * n);
      out.reflectivity = 0.25f;
      break;
    }
    case GroundSurface::kCobble: {
      const int row = static_cast<int>(std::floor(g.s / 0.14f));
      const float ss = g.l + ((row & 1) ? 0.07f : 0.f);
      const float stone = boxPulse(ss, 0.14f, 0.12f, g.fl) * boxPulse(g.s, 0.14f, 0.12f, g.fs);
      const float rs = cellRandom(static_cast<int>(std::floor(ss / 0.14f)), row, seed + 7u) - 0.5f;
      const float resolved = lodWeight(0.14f, std::max(g.fs, g.fl));
      out.albedo = Vec3(0.42f, 0.4f, 0.38f) * (1.f + 0.4f * rs * resolved) * (0.5f + 0.5f * stone) *
                   (1.f + 0.1f * fractalNoise(g.x, g.y, 0.1f, 3, 0.8f, g.fp, seed + 8u));
      out.reflectivity = 0.2f;
      break;
    }
    case GroundSurface::kField: {
      const float crop = valueNoise(g.x / 45.f, g.y / 45.f, seed + 9u);
      const Vec3 green(0.22f, 0.32f, 0.12f), brown(0.38f, 0.32f, 0.2f);
      out.albedo = (green + (brown - green) * clamp01(0.5f + crop)) *
                   (1.f + 0.3f * fractalNoise(g.x, g.y, 2.f, 6, 0.75f, g.fp, seed + 10u));
      out.reflectivity = 0.3f;
      break;
    }
  }
  return out;
}

}  // namespace

SurfaceLook shadePrimitive(const Primitive& p, const SurfacePoint& sp) {
  const float fp = sp.footprint();
  switch (p.material) {
    case Material::kBrickFacade:
    case Material::kPlasterFacade:
    case Material::kHouseWall: {
      if (!isSide(sp)) return gravelRoof(sp, Vec3(0.33f, 0.32f, 0.31f), p.style, fp);
      const FaceFrame f = faceFrame(p, sp);
      if (p.material == Material::kBrickFacade) return brickFacade(p, f, fp);
      if (p.material == Material::kPlasterFacade) return plasterFacade(p, f, fp);
      return houseWall(p, f, fp);
    }
    case Material::kTileRoof:
      return tileRoof(p, sp, fp);
    case Material::kCurb:
      return curb(p, sp, fp);
    case Material::kCarBody:
      return carBody(p, sp, fp);
    case Material::kCarCabin:
      return carCabin(p, sp, fp);
    case Material::kTire:
      return tire(p, sp, fp);
    case Material::kBark:
      return bark(p, sp, fp);
    case Material::kFoliage:
      return foliage(p, sp, fp, 0.6f);
    case Material::kHedge:
      return foliage(p, sp, fp, 0.35f);
    case Material::kMetal:
      return noisy3d(p, sp, fp, 0.08f, 0.35f);
    case Material::kSign:
      return sign(p, sp, fp);
    case Material::kGuardRail:
      return guardRail(p, sp, fp);
    case Material::kConcrete:
      return noisy3d(p, sp, fp, 0.15f, 0.35f);
    case Material::kFence:
      return fence(p, sp, fp);
  }
  return SurfaceLook{};
}

SurfaceLook shadeGround(const RoadPath& road, const GroundLayout& layout, const SurfacePoint& sp,
                        uint32_t seed) {
  GroundCoords g;
  g.x = sp.world.x();
  g.y = sp.world.y();
  g.fp = sp.footprint();
  Eigen::Vector2f t;
  if (!road.toRoad(g.x, g.y, &g.s, &g.l, &t)) {
    g.s = g.x, g.l = g.y, g.fs = g.fl = g.fp;
    return groundSurface(layout.outside, g, seed, layout.asphalt_texture);
  }
  const Vec3 along(t.x(), t.y(), 0.f), across(-t.y(), t.x(), 0.f);
  g.fs = sp.footprintAlong(along);
  g.fl = sp.footprintAlong(across);
  // The band under the pixel centre, blended with its neighbour where the pixel straddles an edge.
  const GroundBand* band = nullptr;
  for (const auto& b : layout.bands)
    if (g.l >= b.l0 && g.l < b.l1) band = &b;
  SurfaceLook out;
  if (!band) {
    out = groundSurface(layout.outside, g, seed, layout.asphalt_texture);
  } else {
    out = groundSurface(band->surface, g, seed, layout.asphalt_texture);
    const float own = boxBand(g.l, band->l0, band->l1, g.fl);
    if (own < 1.f) {
      const float edge = (g.l - band->l0 < band->l1 - g.l) ? band->l0 - 1e-3f : band->l1 + 1e-3f;
      GroundSurface other = layout.outside;
      for (const auto& b : layout.bands)
        if (edge >= b.l0 && edge < b.l1) other = b.surface;
      if (other != band->surface) {
        const SurfaceLook o = groundSurface(other, g, seed, layout.asphalt_texture);
        out.albedo = out.albedo * own + o.albedo * (1.f - own);
        out.reflectivity = out.reflectivity * own + o.reflectivity * (1.f - own);
      }
    }
  }
  float paint = 0.f;
  for (const auto& m : layout.markings) {
    float cov = boxBand(g.l, m.l - 0.5f * m.width, m.l + 0.5f * m.width, g.fl);
    if (cov <= 0.f) continue;
    if (m.dash > 0.f) cov *= boxPulse(g.s, m.dash + m.gap, m.dash, g.fs);
    paint = std::max(paint, cov);
  }
  if (paint > 0.f) {
    const float wear = 0.85f + 0.15f * fractalNoise(g.x, g.y, 0.3f, 3, 0.7f, g.fp, seed + 12u);
    const Vec3 white = Vec3(0.85f, 0.85f, 0.82f) * wear;
    out.albedo = out.albedo * (1.f - paint) + white * paint;
    out.reflectivity = out.reflectivity * (1.f - paint) + 0.75f * paint;
  }
  return out;
}

}  // namespace sim
}  // namespace tescalib
