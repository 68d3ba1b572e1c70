// Cameras: pinhole / orthographic projection in the OpenGL convention, and the ring of cameras
// framing a tree's bounding sphere.
//
// Pixel convention: x right, y down, continuous coordinates with pixel (i, j) covering
// [i, i+1) × [j, j+1) and its centre at (i + 0.5, j + 0.5); principal point (w/2, h/2).
// Camera space: x right, y up, z back (the camera looks along −z); depth = −z_camera.
#include "pipeline/render/camera.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace sylva {

namespace {

Vec3 column(const Camera& c, int j) {
    return {c.cameraToWorld[0][j], c.cameraToWorld[1][j], c.cameraToWorld[2][j]};
}

void setColumn(Camera& c, int j, const Vec3& v) {
    c.cameraToWorld[0][j] = v.x;
    c.cameraToWorld[1][j] = v.y;
    c.cameraToWorld[2][j] = v.z;
}

}  // namespace

BoundingSphere treeBoundingSphere(const Tree& tree) {
    Aabb box;
    for (const SkeletonNode& n : tree.nodes) {
        const double r = std::max(0.0, n.radius);
        box.extend(n.position - Vec3{r, r, r});
        box.extend(n.position + Vec3{r, r, r});
    }
    auto forEachCorner = [&](auto&& f) {
        for (const Leaf& leaf : tree.leaves) {
            const Vec3 along = leaf.tangent * (0.5 * leaf.size);
            const Vec3 across = cross(leaf.normal, leaf.tangent) * (0.5 * leaf.size * leaf.aspect);
            for (double s : {-1.0, 1.0}) {
                for (double t : {-1.0, 1.0}) f(leaf.position + along * s + across * t);
            }
        }
    };
    forEachCorner([&](const Vec3& p) { box.extend(p); });
    BoundingSphere sphere;
    if (box.empty() ||
        !std::isfinite(box.lo.x + box.lo.y + box.lo.z + box.hi.x + box.hi.y + box.hi.z)) {
        return sphere;  // the origin, radius 1
    }
    sphere.centre = box.center();
    double r = 0.0;
    for (const SkeletonNode& n : tree.nodes) {
        r = std::max(r, distance(n.position, sphere.centre) + std::max(0.0, n.radius));
    }
    forEachCorner([&](const Vec3& p) { r = std::max(r, distance(p, sphere.centre)); });
    sphere.radius = r > 0 ? r : 1.0;  // a single point: frame a 1 m sphere around it
    return sphere;
}

NgpPlacement ngpPlacement(const Tree& tree) { return ngpPlacement(treeBoundingSphere(tree)); }

NgpPlacement ngpPlacement(const BoundingSphere& sphere) {
    NgpPlacement p;
    p.scale = 1.0 / (2.0 * kNgpCubeMargin * sphere.radius);
    p.offset = Vec3{0.5, 0.5, 0.5} - sphere.centre * p.scale;
    return p;
}

double Camera::fx() const {
    if (orthographic) return orthoHeight > 0 ? height / orthoHeight : 0.0;
    return 0.5 * height / std::tan(0.5 * fovY);
}

double Camera::fy() const { return fx(); }

bool Camera::project(const Vec3& world, double& px, double& py, double& depth) const {
    const Vec3 d = world - column(*this, 3);
    const double xc = dot(d, column(*this, 0));
    const double yc = dot(d, column(*this, 1));
    const double zc = dot(d, column(*this, 2));
    depth = -zc;
    const double f = fx();
    if (orthographic) {
        px = cx() + f * xc;
        py = cy() - f * yc;
    } else {
        if (!(depth > 0)) {
            px = py = 0.0;
            return false;
        }
        px = cx() + f * xc / depth;
        py = cy() - f * yc / depth;
    }
    return depth > 0;
}

Vec3 Camera::unproject(double px, double py, double depth) const {
    return unproject(px, py, depth, fx());
}

Vec3 Camera::unproject(double px, double py, double depth, double f) const {
    double xc = (px - cx()) / f;
    double yc = (cy() - py) / f;
    if (!orthographic) {
        xc *= depth;
        yc *= depth;
    }
    return column(*this, 3) + column(*this, 0) * xc + column(*this, 1) * yc +
           column(*this, 2) * (-depth);
}

std::vector<Camera> makeCameras(const Tree& tree, const ViewOptions& options, Rng& rng) {
    if (options.count <= 0) return {};
    return makeCameras(treeBoundingSphere(tree), options, rng);
}

std::vector<Camera> makeCameras(const BoundingSphere& sphere, const ViewOptions& options,
                                Rng& rng) {
    std::vector<Camera> cameras;
    if (options.count <= 0) return cameras;
    if (options.width <= 0 || options.height <= 0) {
        throw std::invalid_argument("views: image size must be positive, got " +
                                    std::to_string(options.width) + "x" +
                                    std::to_string(options.height));
    }
    if (options.elevationsDeg.empty() ||
        (options.elevationRange && options.elevationsDeg.size() < 2)) {
        throw std::invalid_argument(options.elevationRange
                                        ? "views: an elevation range needs two values"
                                        : "views: at least one elevation is needed");
    }
    if (!options.orthographic && !(options.fovDeg > 0 && options.fovDeg < 180)) {
        throw std::invalid_argument("views: field of view must be in (0, 180) degrees, got " +
                                    std::to_string(options.fovDeg));
    }
    if (!(options.margin > 0)) {
        throw std::invalid_argument("views: margin must be positive");
    }

    const Vec3 centre = sphere.centre;
    const double radius = sphere.radius;
    const double framed = radius * options.margin;
    const double aspect = static_cast<double>(options.width) / options.height;

    const double offsetDeg =
        options.randomAzimuth ? rng.uniform(0.0, 360.0) : options.azimuthOffsetDeg;
    const double fovY = options.fovDeg * kPi / 180.0;
    // The sphere must fit the narrower image dimension: for tall images (w < h) the horizontal
    // field of view (perspective) or width (orthographic) is the limiting one.
    const double fovX = 2.0 * std::atan(std::tan(0.5 * fovY) * aspect);
    const double fovMin = std::min(fovY, fovX);

    cameras.reserve(options.count);
    for (int k = 0; k < options.count; ++k) {
        Camera cam;
        cam.width = options.width;
        cam.height = options.height;
        cam.orthographic = options.orthographic;
        cam.fovY = fovY;
        cam.azimuthDeg = offsetDeg + 360.0 * k / options.count;
        if (options.elevationRange) {
            const double e0 = options.elevationsDeg[0], e1 = options.elevationsDeg[1];
            cam.elevationDeg = options.count > 1 ? e0 + (e1 - e0) * k / (options.count - 1.0) : e0;
        } else {
            cam.elevationDeg = options.elevationsDeg[k % options.elevationsDeg.size()];
        }
        const double az = cam.azimuthDeg * kPi / 180.0;
        const double el = cam.elevationDeg * kPi / 180.0;
        // Azimuth 0 puts the camera on +z looking along −z (the preview's front view);
        // azimuth turns it right-handedly about +y. Elevation lifts it above the horizon.
        const Vec3 back{std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az)};
        const Vec3 right{std::cos(az), 0.0, -std::sin(az)};  // stays level, even at ±90°
        const Vec3 up = cross(back, right);
        double dist;
        if (options.orthographic) {
            cam.orthoHeight = 2.0 * framed * std::max(1.0, 1.0 / aspect);
            dist = 3.0 * radius;
        } else {
            dist = framed / std::sin(0.5 * fovMin);
        }
        setColumn(cam, 0, right);
        setColumn(cam, 1, up);
        setColumn(cam, 2, back);
        setColumn(cam, 3, centre + back * dist);
        cam.cameraToWorld[3][3] = 1.0;
        cameras.push_back(cam);
    }
    return cameras;
}

}  // namespace sylva
