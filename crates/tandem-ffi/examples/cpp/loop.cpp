// tandem's controller in a C++17 1 kHz loop of the shape libfranka, ur_rtde and ros2_control
// use: a hardware stand-in that is read() and written each period, and a controller whose
// update() turns the readings into joint torques. The tandem handle is wrapped with RAII
// (tandem::Controller frees it) and every status other than TANDEM_OK becomes a
// tandem::Error exception carrying the status and the message.
//
// There is no robot: StandInRobot returns the scenario's start state every period (a real
// interface returns the encoders and the wrist F/T readings taken with the last torque held).
//
// Build (from the repository root, after `cargo build --release -p tandem-ffi`):
//   c++ -std=c++17 -O2 -I crates/tandem-ffi/include crates/tandem-ffi/examples/cpp/loop.cpp
//       -L target/release -ltandem_ffi -Wl,-rpath,$PWD/target/release -o loop_cpp
//   ./loop_cpp [TICKS [--free-run]]     (1000 ticks paced at the control period by default)
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tandem.h"

namespace tandem {

/// A failed tandem call: its status and message.
class Error : public std::runtime_error {
  public:
    Error(TandemStatus status, const std::string &what)
        : std::runtime_error(what), status_(status) {}
    TandemStatus status() const noexcept { return status_; }

  private:
    TandemStatus status_;
};

/// Throw tandem::Error unless `s` is TANDEM_OK.
inline void check(TandemStatus s, const char *call) {
    if (s != TANDEM_OK) {
        throw Error(s, std::string(call) + ": " + tandem_status_name(s) + ": " +
                           tandem_last_error());
    }
}

/// A scenario's controller, owned: moved, never copied; freed on destruction. Used by one
/// thread at a time (a handle is Send, not Sync).
class Controller {
  public:
    static Controller preset(const char *name, const char *law = nullptr) {
        TandemController *h = nullptr;
        check(tandem_controller_new_preset(name, law, &h), "tandem_controller_new_preset");
        return Controller(h);
    }
    static Controller from_toml(const std::string &text, const char *law = nullptr) {
        TandemController *h = nullptr;
        check(tandem_controller_new(text.c_str(), law, &h), "tandem_controller_new");
        return Controller(h);
    }
    Controller(Controller &&o) noexcept : h_(std::exchange(o.h_, nullptr)) {}
    Controller &operator=(Controller &&o) noexcept {
        std::swap(h_, o.h_);
        return *this;
    }
    Controller(const Controller &) = delete;
    Controller &operator=(const Controller &) = delete;
    ~Controller() { tandem_controller_free(h_); }

    std::size_t n_q() const { return get_size(tandem_n_q, "tandem_n_q"); }
    std::size_t n_wrench() const {
        return get_size(tandem_n_arms, "tandem_n_arms") *
               get_size(tandem_wrench_dim, "tandem_wrench_dim");
    }
    double period() const {
        double dt = 0.0;
        check(tandem_control_period(h_, &dt), "tandem_control_period");
        return dt;
    }
    void start_state(std::vector<double> &q, std::vector<double> &qd,
                     std::vector<double> &w) const {
        q.assign(n_q(), 0.0);
        qd.assign(n_q(), 0.0);
        w.assign(n_wrench(), 0.0);
        check(tandem_start_state(h_, q.data(), q.size(), qd.data(), qd.size(), w.data(),
                                 w.size()),
              "tandem_start_state");
    }
    void start(double t, const std::vector<double> &q, const std::vector<double> &qd,
               const std::vector<double> &w) {
        check(tandem_start(h_, t, q.data(), q.size(), qd.data(), qd.size(), w.data(), w.size()),
              "tandem_start");
    }
    /// The real-time call: no allocation on either side (unless it throws).
    void tick(double t, const std::vector<double> &q, const std::vector<double> &qd,
              const std::vector<double> &w, std::vector<double> &tau) {
        check(tandem_tick(h_, t, q.data(), q.size(), qd.data(), qd.size(), w.data(), w.size(),
                          tau.data(), tau.size()),
              "tandem_tick");
    }
    std::vector<double> record(const char *name) const {
        std::size_t n = 0;
        check(tandem_record_vector(h_, name, nullptr, 0, &n), "tandem_record_vector");
        std::vector<double> v(n);
        check(tandem_record_vector(h_, name, v.data(), v.size(), nullptr),
              "tandem_record_vector");
        return v;
    }

  private:
    explicit Controller(TandemController *h) : h_(h) {}
    std::size_t get_size(TandemStatus (*f)(TandemController *, std::size_t *),
                         const char *call) const {
        std::size_t n = 0;
        check(f(h_, &n), call);
        return n;
    }
    TandemController *h_ = nullptr;
};

}  // namespace tandem

/// The robot's side: what libfranka's RobotState, ur_rtde's RTDEReceiveInterface or a
/// ros2_control hardware interface's state interfaces give each period, and where the
/// command goes. Here: the start state, held.
class StandInRobot {
  public:
    StandInRobot(std::vector<double> q, std::vector<double> qd, std::vector<double> w)
        : q_(std::move(q)), qd_(std::move(qd)), w_(std::move(w)), tau_(q_.size(), 0.0) {}
    void read(std::vector<double> &q, std::vector<double> &qd, std::vector<double> &w) const {
        std::copy(q_.begin(), q_.end(), q.begin());
        std::copy(qd_.begin(), qd_.end(), qd.begin());
        std::copy(w_.begin(), w_.end(), w.begin());
    }
    void write(const std::vector<double> &tau) {
        std::copy(tau.begin(), tau.end(), tau_.begin());
    }

  private:
    std::vector<double> q_, qd_, w_, tau_;
};

/// The loop's three steps, as a ros2_control controller/hardware pair splits them: read() the
/// state interfaces, update() the controller, write() the command interfaces. Every buffer is
/// allocated here, before the loop.
class CooperativeLoop {
  public:
    CooperativeLoop(tandem::Controller c, StandInRobot &robot)
        : c_(std::move(c)), robot_(robot), q_(c_.n_q()), qd_(c_.n_q()), w_(c_.n_wrench()),
          tau_(c_.n_q()) {}
    void on_activate(double t0) {
        robot_.read(q_, qd_, w_);
        c_.start(t0, q_, qd_, w_);
    }
    void read() { robot_.read(q_, qd_, w_); }
    void update(double t) { c_.tick(t, q_, qd_, w_, tau_); }
    void write() { robot_.write(tau_); }
    const std::vector<double> &tau() const { return tau_; }
    tandem::Controller &controller() { return c_; }

  private:
    tandem::Controller c_;
    StandInRobot &robot_;
    std::vector<double> q_, qd_, w_, tau_;
};

int main(int argc, char **argv) {
    const int ticks = argc > 1 ? std::atoi(argv[1]) : 1000;
    const bool paced = !(argc > 2 && std::strcmp(argv[2], "--free-run") == 0);
    try {
        auto c = tandem::Controller::preset("dual-ur5", "nn");
        const double dt = c.period();
        std::vector<double> q, qd, w;
        c.start_state(q, qd, w);
        StandInRobot robot(q, qd, w);
        CooperativeLoop loop(std::move(c), robot);

        using clock = std::chrono::steady_clock;
        const auto period = std::chrono::duration_cast<clock::duration>(
            std::chrono::duration<double>(dt));
        loop.on_activate(0.0);
        auto next = clock::now();
        int overruns = 0;
        for (int k = 0; k < ticks; ++k) {
            loop.read();
            loop.update(k * dt);
            loop.write();
            if (k % 100 == 0 || k == ticks - 1) {
                std::printf("tau %d", k);
                for (double v : loop.tau()) std::printf(" %.17g", v);
                std::printf("\n");
            }
            next += period;
            if (paced) {
                if (clock::now() > next) ++overruns;
                std::this_thread::sleep_until(next);
            }
        }
        std::printf("z1");
        for (double v : loop.controller().record("z1")) std::printf(" %.17g", v);
        std::printf("\n");
        std::printf("overruns %d of %d periods (%s)\n", overruns, ticks,
                    paced ? "paced" : "free-running");

        // A status other than TANDEM_OK is an exception; the controller is unchanged after it.
        try {
            loop.update(0.0);  // time goes back
        } catch (const tandem::Error &e) {
            std::printf("caught: %s\n", e.what());
        }
        loop.read();
        loop.update(ticks * dt);
        std::printf("next tick: ok\n");
    } catch (const tandem::Error &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 1;
    }
    return 0;
}
