// lamina_press (C++): reads a running `lamina run` through lamina.hpp, the RAII wrapper over
// lamina-client's C ABI. Takes --frames node frames in order (the sequence must rise and
// every frame carry every node), then presses the scene's sphere into the top of the skin
// 2, 4 and 6 mm deep and checks that the skin pushes back harder each time. Exits 0 when
// every check holds, 1 otherwise, 2 on a bad argument.
//
//   cargo build --release -p lamina-client
//   cmake -S examples/cpp -B build/cpp && cmake --build build/cpp
//   ./target/release/lamina run --prefix demo &
//   ./build/cpp/lamina_press --prefix demo
#include "lamina.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <thread>

namespace {

using Clock = std::chrono::steady_clock;

// Holds the sphere at `centre` for `seconds`, commanding every 2 ms; the mean upward force of
// the second half's feedback (N) and whether all of it was in contact.
std::pair<double, bool> hold(const lamina::Client &client, const std::array<double, 3> &centre, double radius,
                             double seconds) {
    auto start = Clock::now();
    auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
    double sum = 0.0;
    int kept = 0;
    bool contact = true;
    uint64_t last = std::numeric_limits<uint64_t>::max();
    while (elapsed() < seconds) {
        client.send_sphere(centre, radius);
        LaminaFeedback fb = client.latest_feedback();
        if (elapsed() >= seconds / 2 && fb.sequence != last) {
            sum += fb.force[1];
            contact = contact && fb.in_contact == 1;
            kept++;
        }
        last = fb.sequence;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return {kept ? sum / kept : 0.0, kept > 0 && contact};
}

int run(const std::string &prefix, long frames) {
    lamina::Client client(prefix, 60000);
    LaminaTopologyInfo topo = client.topology();
    std::printf("topology of '%s': %u nodes, %u triangles, %u springs, %u layers, %u surfaces\n", topo.model_name,
                topo.node_count, topo.triangle_count, topo.spring_count, topo.layer_count, topo.surface_count);
    for (uint32_t i = 0; i < topo.layer_count; i++) {
        LaminaLayerInfo layer = client.layer(i);
        std::printf("  layer %s: %u nodes from %u\n", layer.name, layer.node_count, layer.first_node);
    }

    std::vector<float> x;
    LaminaFrameInfo f = client.next_frame(x, 10000);
    uint64_t first = f.sequence, last = f.sequence, gaps = 0;
    for (long k = 1; k < frames; k++) {
        f = client.next_frame(x, 10000);
        if (f.sequence <= last || f.node_count != topo.node_count) {
            std::fprintf(stderr, "lamina_press: sequence %llu after %llu, %u nodes of %u\n",
                         static_cast<unsigned long long>(f.sequence), static_cast<unsigned long long>(last),
                         f.node_count, topo.node_count);
            return 1;
        }
        gaps += f.sequence - last - 1;
        last = f.sequence;
    }
    std::printf("%ld frames, sequence %llu..%llu, %llu lost, %u nodes each\n", frames,
                static_cast<unsigned long long>(first), static_cast<unsigned long long>(last),
                static_cast<unsigned long long>(gaps), topo.node_count);
    if (gaps * 50 > static_cast<uint64_t>(frames)) {
        std::fprintf(stderr, "lamina_press: more than 2 %% of the frames lost\n");
        return 1;
    }

    // The top of the skin nearest the middle of the model in x and z (the models are y up).
    size_t n = topo.node_count;
    double lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = std::numeric_limits<double>::infinity();
        hi[a] = -lo[a];
    }
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = std::fmin(lo[a], x[3 * i + a]);
            hi[a] = std::fmax(hi[a], x[3 * i + a]);
        }
    size_t touch = 0;
    double best = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < n; i++) {
        double dx = x[3 * i] - (lo[0] + hi[0]) / 2, dz = x[3 * i + 2] - (lo[2] + hi[2]) / 2;
        if (x[3 * i + 1] >= hi[1] - 1e-3 && dx * dx + dz * dz < best) {
            best = dx * dx + dz * dz;
            touch = i;
        }
    }
    double r = topo.tool.radius_m;
    std::array<double, 3> top{x[3 * touch], x[3 * touch + 1], x[3 * touch + 2]};
    std::printf("pressing node %zu at (%.4f, %.4f, %.4f) m with a %.1f mm sphere\n", touch, top[0], top[1], top[2],
                r * 1e3);
    double previous = 0.0;
    for (double depth_mm : {2.0, 4.0, 6.0}) {
        auto [up, contact] = hold(client, {top[0], top[1] + r - depth_mm * 1e-3, top[2]}, r, 0.5);
        std::printf("depth %.1f mm: force up %.4f N, in contact %s\n", depth_mm, up, contact ? "yes" : "no");
        if (!contact || up <= previous) {
            std::fprintf(stderr, "lamina_press: the force does not rise with depth\n");
            return 1;
        }
        previous = up;
    }
    hold(client, {top[0], top[1] + r + 0.02, top[2]}, r, 0.1);
    std::printf("ok\n");
    return 0;  // ~Client closes the connection
}

}  // namespace

int main(int argc, char **argv) {
    std::string prefix = "lamina";
    long frames = 1000;
    for (int i = 1; i < argc; i++) {
        if (std::strcmp(argv[i], "--prefix") == 0 && i + 1 < argc) {
            prefix = argv[++i];
        } else if (std::strcmp(argv[i], "--frames") == 0 && i + 1 < argc) {
            char *end;
            frames = std::strtol(argv[++i], &end, 10);
            if (*end != '\0' || frames < 2 || frames > 1000000) {
                std::fprintf(stderr, "lamina_press: --frames %s: give a whole number from 2 to 1000000\n", argv[i]);
                return 2;
            }
        } else {
            std::fprintf(stderr, "usage: lamina_press [--prefix P] [--frames N]\n");
            return 2;
        }
    }
    try {
        return run(prefix, frames);
    } catch (const lamina::Error &e) {
        std::fprintf(stderr, "lamina_press: %s\n", e.what());
        return 1;
    }
}
