// lamina.hpp: a C++17 RAII wrapper over lamina-client's C ABI (lamina.h).
//
// lamina::Client opens a core on construction and closes it on destruction; it moves but does
// not copy. Every failing call throws lamina::Error with the status code and the library's
// message. Like the C handle, a Client is used on the thread that opened it.
#pragma once

#include <lamina.h>

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace lamina {

/// A failed call: the status and the library's message.
class Error : public std::runtime_error {
public:
    Error(LaminaStatus status, const std::string &what)
        : std::runtime_error(what + ": " + lamina_status_name(status) + ": " + lamina_last_error_message()),
          status_(status) {}
    LaminaStatus status() const noexcept { return status_; }

private:
    LaminaStatus status_;
};

inline void check(LaminaStatus status, const char *what) {
    if (status != LAMINA_STATUS_OK) throw Error(status, what);
}

/// A connection to one Lamina core.
class Client {
public:
    /// Joins the core on `prefix`, waiting up to `timeout_ms` for its topology.
    explicit Client(const std::string &prefix = "lamina", uint32_t timeout_ms = 10000) {
        check(lamina_open(prefix.c_str(), timeout_ms, &handle_), "lamina_open");
    }
    ~Client() {
        if (handle_ != 0) lamina_close(handle_);
    }
    Client(const Client &) = delete;
    Client &operator=(const Client &) = delete;
    Client(Client &&other) noexcept : handle_(std::exchange(other.handle_, 0)) {}
    Client &operator=(Client &&other) noexcept {
        if (this != &other) {
            if (handle_ != 0) lamina_close(handle_);
            handle_ = std::exchange(other.handle_, 0);
        }
        return *this;
    }

    LaminaClient handle() const noexcept { return handle_; }

    LaminaTopologyInfo topology() const {
        LaminaTopologyInfo info{};
        check(lamina_topology_info(handle_, &info), "lamina_topology_info");
        return info;
    }
    LaminaLayerInfo layer(uint32_t index) const {
        LaminaLayerInfo info{};
        check(lamina_layer_info(handle_, index, &info), "lamina_layer_info");
        return info;
    }
    LaminaSurfaceInfo surface(uint32_t index) const {
        LaminaSurfaceInfo info{};
        check(lamina_surface_info(handle_, index, &info), "lamina_surface_info");
        return info;
    }
    std::vector<uint32_t> surface_indices(uint32_t index) const {
        std::vector<uint32_t> out(surface(index).index_count);
        size_t count = 0;
        check(lamina_surface_indices(handle_, index, out.data(), out.size(), &count), "lamina_surface_indices");
        out.resize(count);
        return out;
    }
    /// Rest positions, x y z per node, m.
    std::vector<float> rest_positions() const {
        std::vector<float> out(3 * static_cast<size_t>(topology().node_count));
        size_t count = 0;
        check(lamina_rest_positions(handle_, out.data(), out.size() / 3, &count), "lamina_rest_positions");
        out.resize(3 * count);
        return out;
    }

    /// The oldest queued frame into `positions` (resized to 3 floats per node).
    LaminaFrameInfo next_frame(std::vector<float> &positions, uint32_t timeout_ms = 1000) const {
        return frame(positions, timeout_ms, false);
    }
    /// The newest frame into `positions`, older queued ones dropped.
    LaminaFrameInfo latest_frame(std::vector<float> &positions, uint32_t timeout_ms = 1000) const {
        return frame(positions, timeout_ms, true);
    }

    /// The sphere's centre at `p` (m, model frame), radius `radius_m` (0: the scene's).
    void send_sphere(const std::array<double, 3> &p, double radius_m = 0.0) const {
        check(lamina_send_sphere(handle_, p[0], p[1], p[2], radius_m), "lamina_send_sphere");
    }
    /// As send_sphere, holding (`closed`) or letting go of the nodes near the sphere.
    void send_grasp(const std::array<double, 3> &p, double radius_m, bool closed) const {
        check(lamina_send_grasp(handle_, p[0], p[1], p[2], radius_m, closed ? 1u : 0u), "lamina_send_grasp");
    }
    /// The scalpel's tip at `p` (m, model frame), its cutting edge straight up (+y) from the
    /// tip, `blade_length_m` long (0: the scene's).
    void send_scalpel(const std::array<double, 3> &p, double blade_length_m = 0.0) const {
        check(lamina_send_scalpel(handle_, p[0], p[1], p[2], blade_length_m), "lamina_send_scalpel");
    }
    LaminaFeedback latest_feedback(uint32_t timeout_ms = 1000) const {
        LaminaFeedback fb{};
        check(lamina_latest_feedback(handle_, timeout_ms, &fb), "lamina_latest_feedback");
        return fb;
    }

private:
    LaminaFrameInfo frame(std::vector<float> &positions, uint32_t timeout_ms, bool newest) const {
        if (nodes_ == 0) nodes_ = topology().node_count;
        positions.resize(3 * nodes_);
        LaminaFrameInfo info{};
        auto call = newest ? lamina_latest_frame : lamina_next_frame;
        check(call(handle_, timeout_ms, positions.data(), nodes_, &info), newest ? "lamina_latest_frame" : "lamina_next_frame");
        return info;
    }

    LaminaClient handle_ = 0;
    mutable size_t nodes_ = 0;
};

}  // namespace lamina
