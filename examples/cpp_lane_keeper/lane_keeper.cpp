// A lane keeper behind simgap's planner protocol (../../planner-protocol/simgap_planner.proto),
// in C++: it drives along simgap's route centre line at a constant speed.
//
// Started by simgap (`--planner exec:path/to/lane_keeper`) it binds the endpoint in
// SIMGAP_PLANNER_ENDPOINT and exits once the last session is closed; started by hand with an
// endpoint (`lane_keeper tcp://*:5555`) it serves every run that connects until it is stopped.
#include <zmq.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "simgap_planner.pb.h"

namespace pb = simgap::planner::v1;

static const char* PROTOCOL_VERSION = "1.0";
static const double PI = 3.14159265358979323846;
static const double HORIZON_S = 3.0;     // length of each plan
static const double CRUISE_SPEED = 5.0;  // [m/s] when slower (settings: {"cruise_speed": ...})
static const double ACCEL = 1.5;         // [m/s^2] up to the cruise speed

// A column of the protocol: float64 values, little-endian (the host's order, checked here).
static_assert(std::endian::native == std::endian::little, "a column is copied as it is in memory");

static std::vector<double> values_of(const std::string& bytes) {
  if (bytes.size() % 8) throw std::invalid_argument("a column of " + std::to_string(bytes.size()) + " bytes");
  std::vector<double> out(bytes.size() / 8);
  std::memcpy(out.data(), bytes.data(), bytes.size());
  return out;
}

static std::string bytes_of(const std::vector<double>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), 8 * values.size());
}

// The route centre line by arc length: position, heading and curvature anywhere along it.
class LaneKeeper {
 public:
  explicit LaneKeeper(const pb::Initialize& init) : dt_(init.dt()), wheelbase_(init.vehicle().wheelbase()) {
    std::vector<double> rx = values_of(init.route().x()), ry = values_of(init.route().y());
    if (rx.size() < 2 || rx.size() != ry.size()) throw std::invalid_argument("the route needs 2 points or more");
    if (!(dt_ > 0)) throw std::invalid_argument("dt must be positive");
    for (size_t i = 0; i < rx.size(); ++i) {
      double step = x_.empty() ? 0.0 : std::hypot(rx[i] - x_.back(), ry[i] - y_.back());
      if (!x_.empty() && step < 1e-6) continue;  // every segment has a length
      s_.push_back(x_.empty() ? 0.0 : s_.back() + step);
      x_.push_back(rx[i]), y_.push_back(ry[i]);
    }
    if (x_.size() < 2) throw std::invalid_argument("the route has no length");
    for (size_t i = 0; i + 1 < x_.size(); ++i) {  // each segment's heading (unwrapped) at its midpoint
      double h = std::atan2(y_[i + 1] - y_[i], x_[i + 1] - x_[i]);
      heading_.push_back(heading_.empty() ? h : heading_.back() + std::remainder(h - heading_.back(), 2 * PI));
      mid_.push_back(0.5 * (s_[i] + s_[i + 1]));
    }
    const std::string& json = init.settings_json();  // the one setting, read without a JSON library
    size_t at = json.find("\"cruise_speed\"");
    if (at != std::string::npos && (at = json.find(':', at)) != std::string::npos)
      cruise_ = std::strtod(json.c_str() + at + 1, nullptr);
    if (!(cruise_ > 0)) throw std::invalid_argument("cruise_speed must be positive");
  }

  // From the observed position's projection on the route, along it: the observed speed held
  // (at least the cruise speed, reached at ACCEL), heading and curvature the route's.
  void plan(const pb::PlanRequest& req, pb::Trajectory* out) const {
    const double v0 = std::max(req.observed().v(), 0.0), cruise = std::max(v0, cruise_);
    const int n = static_cast<int>(std::lround(HORIZON_S / dt_));
    double s = project(req.observed().x(), req.observed().y());
    std::vector<double> t, x, y, yaw, v, a, yaw_rate, steer;
    for (int k = 0; k <= n; ++k) {
      double vk = std::min(cruise, v0 + ACCEL * k * dt_), next = std::min(cruise, vk + ACCEL * dt_), kappa;
      t.push_back(req.t() + k * dt_), v.push_back(vk), a.push_back(k < n ? (next - vk) / dt_ : 0.0);
      x.emplace_back(), y.emplace_back(), yaw.emplace_back();
      along(s, &x.back(), &y.back(), &yaw.back(), &kappa);
      yaw_rate.push_back(vk * kappa), steer.push_back(std::atan(wheelbase_ * kappa));
      s += 0.5 * (vk + next) * dt_;
    }
    out->set_dt(dt_), out->set_t(bytes_of(t)), out->set_x(bytes_of(x)), out->set_y(bytes_of(y));
    out->set_yaw(bytes_of(yaw)), out->set_v(bytes_of(v)), out->set_a(bytes_of(a));
    out->set_yaw_rate(bytes_of(yaw_rate)), out->set_steer(bytes_of(steer));
  }

 private:
  double project(double px, double py) const {  // arc length of the route's point nearest (px, py)
    double best = INFINITY, s = 0.0;
    for (size_t i = 0; i + 1 < x_.size(); ++i) {
      double dx = x_[i + 1] - x_[i], dy = y_[i + 1] - y_[i], len = s_[i + 1] - s_[i];
      double u = std::clamp(((px - x_[i]) * dx + (py - y_[i]) * dy) / (len * len), 0.0, 1.0);
      double d = std::hypot(x_[i] + u * dx - px, y_[i] + u * dy - py);
      if (d < best) best = d, s = s_[i] + u * len;
    }
    return s;
  }

  // The point at arc length s (straight on beyond either end); the heading is interpolated
  // between segment midpoints, so it is continuous and the curvature its slope.
  void along(double s, double* x, double* y, double* yaw, double* kappa) const {
    size_t i = std::min<size_t>(std::upper_bound(s_.begin() + 1, s_.end() - 1, s) - s_.begin(), s_.size() - 1) - 1;
    double u = (s - s_[i]) / (s_[i + 1] - s_[i]);
    *x = x_[i] + u * (x_[i + 1] - x_[i]), *y = y_[i] + u * (y_[i + 1] - y_[i]);
    if (s <= mid_.front() || s >= mid_.back()) {
      *yaw = s <= mid_.front() ? heading_.front() : heading_.back(), *kappa = 0.0;
      return;
    }
    size_t j = std::upper_bound(mid_.begin(), mid_.end(), s) - mid_.begin() - 1;
    *kappa = (heading_[j + 1] - heading_[j]) / (mid_[j + 1] - mid_[j]);
    *yaw = std::remainder(heading_[j] + *kappa * (s - mid_[j]), 2 * PI);
  }

  double dt_, wheelbase_, cruise_ = CRUISE_SPEED;
  std::vector<double> x_, y_, s_, heading_, mid_;
};

static pb::Reply failed(pb::Reply& reply, const std::string& type, const std::string& message) {
  reply.mutable_error()->set_type(type);
  reply.mutable_error()->set_message(message);
  return reply;
}

static pb::Reply answer(const std::string& raw, std::map<uint64_t, LaneKeeper>& sessions, uint64_t& served) {
  pb::Reply reply;
  pb::Request req;
  if (!req.ParseFromString(raw)) return failed(reply, "DecodeError", "not a simgap planner request");
  reply.set_id(req.id());
  try {
    switch (req.body_case()) {
      case pb::Request::kInitialize: {
        const std::string& version = req.initialize().protocol_version();
        if (version.substr(0, version.find('.')) != "1")
          return failed(reply, "ProtocolVersion", "simgap speaks protocol " + version + ", this planner 1.0");
        LaneKeeper keeper(req.initialize());
        sessions.emplace(++served, std::move(keeper));
        reply.mutable_ready()->set_protocol_version(PROTOCOL_VERSION);
        reply.mutable_ready()->set_session(served);
        reply.mutable_ready()->set_planner("cpp_lane_keeper");
        break;
      }
      case pb::Request::kPlan: {
        auto it = sessions.find(req.plan().session());
        if (it == sessions.end())
          return failed(reply, "UnknownSession", "no session " + std::to_string(req.plan().session()));
        it->second.plan(req.plan(), reply.mutable_plan()->mutable_trajectory());
        break;
      }
      case pb::Request::kClose:
        sessions.erase(req.close().session());
        reply.mutable_closed();
        break;
      default:
        return failed(reply, "EmptyRequest", "a request with no body");
    }
  } catch (const std::exception& exc) {  // this request fails, the server goes on
    reply.clear_body();
    failed(reply, "std::exception", exc.what());
  }
  return reply;
}

int main(int argc, char** argv) {
  const char* from_env = std::getenv("SIMGAP_PLANNER_ENDPOINT");
  const bool started_by_simgap = argc < 2;
  const char* endpoint = started_by_simgap ? from_env : argv[1];
  if (!endpoint || !*endpoint) {
    std::cerr << "lane_keeper: no endpoint; simgap gives one in SIMGAP_PLANNER_ENDPOINT, or pass one (tcp://*:5555)\n";
    return 2;
  }
  void* context = zmq_ctx_new();
  void* socket = zmq_socket(context, ZMQ_REP);
  if (zmq_bind(socket, endpoint) != 0) {
    std::cerr << "lane_keeper: cannot bind " << endpoint << ": " << zmq_strerror(zmq_errno()) << "\n";
    return 1;
  }
  std::map<uint64_t, LaneKeeper> sessions;
  uint64_t served = 0;
  int status = 0;
  for (;;) {
    zmq_msg_t msg;
    zmq_msg_init(&msg);
    if (zmq_msg_recv(&msg, socket, 0) < 0) {
      zmq_msg_close(&msg);
      if (zmq_errno() == EINTR) continue;
      std::cerr << "lane_keeper: " << zmq_strerror(zmq_errno()) << "\n";
      status = 1;
      break;
    }
    std::string raw(static_cast<const char*>(zmq_msg_data(&msg)), zmq_msg_size(&msg));
    zmq_msg_close(&msg);
    pb::Reply reply = answer(raw, sessions, served);
    std::string out = reply.SerializeAsString();
    zmq_send(socket, out.data(), out.size(), 0);
    if (started_by_simgap && reply.has_closed() && sessions.empty()) break;
  }
  int linger = 1000;  // long enough for the last reply to leave
  zmq_setsockopt(socket, ZMQ_LINGER, &linger, sizeof linger);
  zmq_close(socket);
  zmq_ctx_term(context);
  return status;
}
