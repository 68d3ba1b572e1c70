// Small vector math shared by every sylva library.
// Frame: right-handed, +y up, lengths in metres, angles in radians.
#pragma once

#include <algorithm>
#include <cmath>

namespace sylva {

constexpr double kPi = 3.14159265358979323846;

struct Vec3 {
    double x = 0, y = 0, z = 0;

    constexpr Vec3() = default;
    constexpr Vec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}

    constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
    double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }

    constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
    constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
    constexpr Vec3 operator-() const { return {-x, -y, -z}; }
    constexpr Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
    constexpr Vec3 operator/(double s) const { return {x / s, y / s, z / s}; }
    Vec3& operator+=(const Vec3& o) {
        x += o.x;
        y += o.y;
        z += o.z;
        return *this;
    }
    Vec3& operator-=(const Vec3& o) {
        x -= o.x;
        y -= o.y;
        z -= o.z;
        return *this;
    }
    Vec3& operator*=(double s) {
        x *= s;
        y *= s;
        z *= s;
        return *this;
    }
    constexpr bool operator==(const Vec3& o) const { return x == o.x && y == o.y && z == o.z; }
};

// A point or vector in a plane: sketched profiles use (x, y) = (distance from the axis,
// height along it); images use (column, row).
struct Vec2 {
    double x = 0, y = 0;

    constexpr Vec2() = default;
    constexpr Vec2(double x_, double y_) : x(x_), y(y_) {}
    constexpr Vec2 operator+(const Vec2& o) const { return {x + o.x, y + o.y}; }
    constexpr Vec2 operator-(const Vec2& o) const { return {x - o.x, y - o.y}; }
    constexpr Vec2 operator*(double s) const { return {x * s, y * s}; }
    constexpr bool operator==(const Vec2& o) const { return x == o.x && y == o.y; }
};
inline constexpr double dot(const Vec2& a, const Vec2& b) { return a.x * b.x + a.y * b.y; }
inline constexpr double cross(const Vec2& a, const Vec2& b) { return a.x * b.y - a.y * b.x; }
inline double length(const Vec2& v) { return std::sqrt(dot(v, v)); }

inline constexpr Vec3 operator*(double s, const Vec3& v) { return v * s; }
inline constexpr double dot(const Vec3& a, const Vec3& b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline constexpr Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline constexpr Vec3 cmul(const Vec3& a, const Vec3& b) {
    return {a.x * b.x, a.y * b.y, a.z * b.z};
}
inline constexpr Vec3 cdiv(const Vec3& a, const Vec3& b) {
    return {a.x / b.x, a.y / b.y, a.z / b.z};
}
inline double length(const Vec3& v) { return std::sqrt(dot(v, v)); }
inline constexpr double length2(const Vec3& v) { return dot(v, v); }
inline double distance(const Vec3& a, const Vec3& b) { return length(a - b); }
inline constexpr double distance2(const Vec3& a, const Vec3& b) { return length2(a - b); }
inline Vec3 normalize(const Vec3& v) {
    double l = length(v);
    return l > 0 ? v / l : Vec3{0, 1, 0};
}
inline Vec3 vmin(const Vec3& a, const Vec3& b) {
    return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
inline Vec3 vmax(const Vec3& a, const Vec3& b) {
    return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
inline Vec3 vabs(const Vec3& a) { return {std::abs(a.x), std::abs(a.y), std::abs(a.z)}; }

// Angle between two non-zero vectors, radians in [0, π].
inline double angleBetween(const Vec3& a, const Vec3& b) {
    double c = dot(a, b) / (length(a) * length(b));
    return std::acos(std::clamp(c, -1.0, 1.0));
}

// Rodrigues rotation of v about the unit axis k by angle a (radians, right-handed).
inline Vec3 rotate(const Vec3& v, const Vec3& k, double a) {
    double c = std::cos(a), s = std::sin(a);
    return v * c + cross(k, v) * s + k * (dot(k, v) * (1 - c));
}

// Any unit vector perpendicular to the unit vector n (deterministic).
inline Vec3 anyPerpendicular(const Vec3& n) {
    Vec3 a = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 0, 1};
    return normalize(cross(n, a));
}

// Orthonormal frame whose second axis (local +y) is the given unit axis.
struct Frame {
    Vec3 u, v, w;  // local x, y (= axis), z in world coordinates

    static Frame fromAxis(const Vec3& axis) {
        Frame f;
        f.v = normalize(axis);
        f.u = anyPerpendicular(f.v);
        f.w = cross(f.u, f.v);
        return f;
    }
    // The shortest-arc rotation taking +y onto the axis: identity for +y, and it varies
    // continuously with the axis (except at −y), unlike fromAxis's arbitrary twist.
    static Frame alignY(const Vec3& axis) {
        const Vec3 n = normalize(axis);
        const double c = n.y;
        if (c < -1.0 + 1e-6) {
            // Near −y the formula below divides by ~0; use (nearly) a half turn about x.
            Frame f;
            f.v = n;
            f.u = normalize(cross(n, {0, 0, -1}));
            f.w = cross(f.u, f.v);
            return f;
        }
        const Vec3 k{n.z, 0.0, -n.x};  // (+y) × n: axis times sin of the angle
        auto turn = [&](const Vec3& e) {
            return e + cross(k, e) + cross(k, cross(k, e)) / (1 + c);
        };
        return {turn({1, 0, 0}), n, turn({0, 0, 1})};
    }
    Vec3 toLocal(const Vec3& p) const { return {dot(p, u), dot(p, v), dot(p, w)}; }
    Vec3 toWorld(const Vec3& p) const { return u * p.x + v * p.y + w * p.z; }
};

// Axis-aligned bounding box; empty when lo > hi.
struct Aabb {
    Vec3 lo{1e300, 1e300, 1e300};
    Vec3 hi{-1e300, -1e300, -1e300};

    bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    void extend(const Vec3& p) {
        lo = vmin(lo, p);
        hi = vmax(hi, p);
    }
    void extend(const Aabb& b) {
        if (!b.empty()) {
            lo = vmin(lo, b.lo);
            hi = vmax(hi, b.hi);
        }
    }
    Vec3 size() const { return hi - lo; }
    Vec3 center() const { return (lo + hi) * 0.5; }
    double volume() const { return empty() ? 0.0 : size().x * size().y * size().z; }
    bool contains(const Vec3& p) const {
        return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z &&
               p.z <= hi.z;
    }
    static Aabb intersect(const Aabb& a, const Aabb& b) {
        Aabb r;
        r.lo = vmax(a.lo, b.lo);
        r.hi = vmin(a.hi, b.hi);
        return r;
    }
};

}  // namespace sylva
