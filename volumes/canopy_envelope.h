// @brief Canopy envelope (Shesh et al., "GPU-friendly parameterized canopies", §3.2, Eq. 1):
// an ellipsoidal or conical domain with radii k = (kx, ky, kz) whose radius is modulated by
//
//     f(φ, θ) = Σ_{i=0..n} pⁱ gᵢ(2ⁱφ, 2ⁱθ)            (Eq. 1; p⁰ = 1 even for p = 0)
//
// where g₀ is the base layer (the constant 1 unless an image is given) and g₁..gₙ are images
// or procedural layers (Gaussian blobs, white noise). Frame: +y up, metres, radians.
//
// Angles and the layer parameterisation (fixed here, used by every method that reads f):
//   ellipsoid: centre at the origin. With q = (x/kx, y/ky, z/kz), φ = atan2(q.z, q.x) ∈ [0, 2π)
//              (azimuth from +x towards +z), θ = acos(q.y/|q|) ∈ [0, π] (polar angle from +y).
//              Inside iff |q| ≤ f(φ, θ). Surface point: f·(kx sinθ cosφ, ky cosθ, kz sinθ sinφ).
//   cone:      base disc at y = 0 with radii (kx, kz), apex at y = ky. φ as above on
//              (x/kx, z/kz); θ = π·(1 − y/ky) (0 at the apex, π at the base). Inside iff
//              0 ≤ y ≤ ky and √((x/kx)² + (z/kz)²) ≤ (1 − y/ky)·f(φ, θ). Only the girth is
//              modulated; the height stays ky.
//   layers:    (φ, θ) ↦ image coordinates (u, v) = (φ/2π, θ/π) ∈ [0, 1)², u across the image
//              (columns), v down it (row 0 at θ = 0, the top). Layer i is read at
//              (frac(2ⁱu), frac(2ⁱv)): it tiles 2ⁱ times in each direction. Every layer is a
//              grid sampled bilinearly between node centres ((j + ½)/width), wrapping in u;
//              images clamp in v (within a tile), procedural layers wrap in v too so their
//              tiles join seamlessly. Note the ellipsoid's poles: f(φ, 0) may depend on φ
//              (as in the paper), so the surface has a small fan-shaped seam at each pole.
//   jitter:    before sampling the layers, φ and θ are perturbed by white noise of amplitude
//              `jitter` (the paper's "perturb the values of ϕ and θ by a small amount"): a
//              64 × 32 value grid over (u, v), drawn once per envelope from its seed and
//              interpolated bilinearly, so f — and the inside test — is a pure function.
//
// f is clamped at 0 (a negative layer amplitude can carve dents, not turn the surface inside
// out). The envelope's extent is k·max f, not k: with g₀ = 1 and layers ≥ 0, f ≥ 1.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/math.h"
#include "core/rng.h"
#include "volumes/volume.h"

namespace sylva {

enum class CanopyDomain { kEllipsoid, kCone };

// A scalar function on the unit square sampled at grid nodes ((j + ½)/width, (r + ½)/height),
// row-major, row 0 at v = 0. Always wraps in u; wraps or clamps in v.
struct CanopyGrid {
    int width = 0, height = 0;
    std::vector<float> values;
    bool wrapV = false;
    bool nearest = false;  // nearest node instead of bilinear interpolation

    double at(double u, double v) const;  // u, v in [0, 1]
    double maxValue() const;
};

// An image read through OpenImageIO: every channel as floats in [0, 1] (8- and 16-bit
// values normalised), interleaved.
struct CanopyImage {
    int width = 0, height = 0, channels = 0;
    std::vector<float> pixels;
    CanopyGrid channel(int c) const;  // one channel as a layer grid (wrap u, clamp v)
};
// Throws ImageError, a std::runtime_error (one line, naming the file), when the file cannot be
// read (volumes/image_file.h: checked before decoding).
CanopyImage readCanopyImage(const std::string& path);

// One function gᵢ.
struct CanopyLayer {
    enum class Kind { kGrid, kBlobs, kNoise };
    Kind kind = Kind::kBlobs;
    // kGrid: an image channel (or any grid built in code).
    CanopyGrid grid;
    // kBlobs (Shesh Figure 2: "centering gaussians at random positions in the image"):
    // g = amplitude · min(1, Σⱼ exp(−dⱼ²/2σ²)), dⱼ the wrap-around uv distance to centre j, so
    // g = amplitude exactly at a centre. Centres are uniform in uv from the layer's stream
    // unless `centres` lists them.
    int count = 12;
    double sigma = 0.08;  // uv units of the layer's own tile
    std::vector<Vec2> centres;
    // kNoise: white noise, a resolution × resolution grid of uniform [0, 1) values.
    int resolution = 32;
    bool nearest = false;  // nearest node (blocky) instead of bilinear
    // kBlobs and kNoise: the layer's values are scaled by this.
    double amplitude = 1.0;
};

struct CanopyEnvelopeOptions {
    CanopyDomain domain = CanopyDomain::kEllipsoid;
    Vec3 radii{1, 1, 1};                  // k = (kx, ky, kz), metres
    double persistence = 0.7;             // p ∈ [0, 1]; the paper uses 0.7 throughout
    double jitter = 2.0 * (kPi / 180.0);  // radians (2°), amplitude of the (φ, θ) white noise
    bool hasBase = false;                 // g₀ = base when set, else the constant 1
    CanopyGrid base;
    std::vector<CanopyLayer> layers;  // g₁ … gₙ, n ≤ 10
};

class CanopyEnvelope : public Volume {
  public:
    // Draws the procedural layers' blobs/noise and the jitter grid from `rng` (stable sub-keys
    // "layers[i]" and "jitter", so adding a layer changes no other layer's draw).
    CanopyEnvelope(const CanopyEnvelopeOptions& options, Rng& rng);

    // Eq. 1 with the jitter applied to (φ, θ) first; clamped at ≥ 0. φ any angle, θ ∈ [0, π].
    double f(double phi, double theta) const;
    // gᵢ(2ⁱφ, 2ⁱθ) without jitter (i = 0 is the base layer); f = max(0, Σ pⁱ·this) at zero jitter.
    double layerValue(size_t i, double phi, double theta) const;
    size_t layerCount() const { return grids_.size(); }  // n + 1, including g₀
    // The point of the envelope's surface at (φ, θ) (see the header comment for both domains).
    Vec3 surfacePoint(double phi, double theta) const;
    // The angles of a point (inverse of surfacePoint's direction), as the inside test uses them.
    Vec2 angles(const Vec3& p) const;  // (φ, θ)

    CanopyDomain domain() const { return o_.domain; }
    const Vec3& radii() const { return o_.radii; }
    double persistence() const { return o_.persistence; }
    double fMax() const { return fMax_; }  // an upper bound of f (from a grid scan + margin)

    // Signed distance: the sign is exact. The magnitude is an approximate lower bound: the
    // radial excess (|q| − f, or the cone's √(…) − (1 − y/ky)·f) divided by a bound on its
    // gradient, built from the layers' Lipschitz constants (max neighbour difference × grid
    // resolution × 2ⁱ, including the jitter's stretch). Near the ellipsoid's poles, where f
    // is discontinuous, it may over-estimate.
    double signedDistance(const Vec3& p) const override;
    Aabb bounds() const override;  // k·fMax (cone: y ∈ [0, ky])
    // Rejection from the domain scaled by fMax (a ball or cone), which is uniform.
    std::optional<Vec3> sample(Rng& rng, int maxTries = 100000) const override;
    // ∫∫ f³/3 · kx ky kz sinθ dθ dφ (ellipsoid) or ∫∫ ½ f² (θ/π)² · kx kz ky/π dθ dφ (cone),
    // by the midpoint rule in φ and exact sinθ / θ² weights per θ row, on a 512 × 256 grid of
    // the jittered f. Computed once at construction.
    double measure() const override { return measure_; }
    std::string describe() const override;

  private:
    double pureSum(double u, double v) const;  // Σ pⁱ gᵢ at image coordinates, no jitter
    double radialExcess(const Vec3& p, double* fOut, double* thetaOut) const;

    CanopyEnvelopeOptions o_;
    std::vector<CanopyGrid> grids_;  // g₀ … gₙ as grids (g₀ = constant 1 if no base)
    std::vector<double> weights_;    // pⁱ
    std::vector<double> tiles_;      // 2ⁱ
    CanopyGrid jitterPhi_, jitterTheta_;
    double fMax_ = 1.0;
    double gPhi_ = 0.0, gTheta_ = 0.0;  // bounds on |∂f/∂φ|, |∂f/∂θ| (per radian)
    double measure_ = 0.0;
};

// The envelope as a volume (a shared_ptr<const CanopyEnvelope> converts to VolumePtr).
std::shared_ptr<const CanopyEnvelope> makeCanopyEnvelope(const CanopyEnvelopeOptions& options,
                                                         Rng& rng);

}  // namespace sylva
