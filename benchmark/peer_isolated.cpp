// A peer's run in a child process with a time limit (see peer_isolated.h).
#include "peer_isolated.h"

#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

namespace collision_response::bench {
namespace {

/// PeerRun as a flat list of doubles: time, body count, 6 per body, impulse count, 3 per impulse,
/// then the note's characters.
std::vector<double> flatten(const PeerRun& r) {
  std::vector<double> out{r.ns_per_solve, static_cast<double>(r.after.linear.size())};
  for (std::size_t i = 0; i < r.after.linear.size(); ++i)
    for (const auto* v : {&r.after.linear[i], &r.after.angular[i]})
      out.insert(out.end(), v->data(), v->data() + 3);
  out.push_back(static_cast<double>(r.impulses.size()));
  for (const auto& p : r.impulses) out.insert(out.end(), p.data(), p.data() + 3);
  for (const char c : r.note) out.push_back(static_cast<double>(static_cast<unsigned char>(c)));
  return out;
}

PeerRun unflatten(const std::vector<double>& in) {
  PeerRun r;
  std::size_t k = 0;
  auto vec = [&] {
    const Eigen::Vector3d v(in[k], in[k + 1], in[k + 2]);
    k += 3;
    return v;
  };
  r.ns_per_solve = in[k++];
  const auto bodies = static_cast<std::size_t>(in[k++]);
  for (std::size_t i = 0; i < bodies; ++i) {
    r.after.linear.push_back(vec());
    r.after.angular.push_back(vec());
  }
  const auto impulses = static_cast<std::size_t>(in[k++]);
  for (std::size_t i = 0; i < impulses; ++i) r.impulses.push_back(vec());
  for (; k < in.size(); ++k) r.note.push_back(static_cast<char>(in[k]));
  return r;
}

PeerRun failed(const std::string& why) {
  PeerRun r;
  r.note = why;
  return r;
}

}  // namespace

PeerRun runIsolated(const std::function<PeerRun()>& run, double time_limit) {
  int fds[2];
  if (pipe(fds) != 0) return failed("not run: pipe() failed");
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t child = fork();
  if (child < 0) {
    close(fds[0]);
    close(fds[1]);
    return failed("not run: fork() failed");
  }
  if (child == 0) {
    close(fds[0]);
    const std::vector<double> data = flatten(run());
    const char* p = reinterpret_cast<const char*>(data.data());
    std::size_t left = data.size() * sizeof(double);
    while (left > 0) {
      const ssize_t n = write(fds[1], p, left);
      if (n <= 0) _exit(1);
      p += n;
      left -= static_cast<std::size_t>(n);
    }
    _exit(0);
  }
  close(fds[1]);
  std::vector<char> bytes;
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(time_limit);
  bool timed_out = false;
  for (;;) {
    const double left =
        std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0.0) {
      timed_out = true;
      break;
    }
    pollfd pfd{fds[0], POLLIN, 0};
    if (poll(&pfd, 1, static_cast<int>(left * 1000.0) + 1) <= 0) continue;
    char buffer[4096];
    const ssize_t n = read(fds[0], buffer, sizeof buffer);
    if (n <= 0) break;  // end of data (or error)
    bytes.insert(bytes.end(), buffer, buffer + n);
  }
  close(fds[0]);
  if (timed_out) kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  if (timed_out) {
    char why[96];
    std::snprintf(why, sizeof why, "not run: did not finish within %.0f s", time_limit);
    return failed(why);
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || bytes.size() % sizeof(double) != 0 ||
      bytes.empty())
    return failed("not run: the peer's process died");
  std::vector<double> data(bytes.size() / sizeof(double));
  std::copy(bytes.begin(), bytes.end(), reinterpret_cast<char*>(data.data()));
  return unflatten(data);
}

}  // namespace collision_response::bench
