// Accuracy sweep: run time against error for every scene of bench_scenes.h and every method (each
// impact law, the exact and the iterative solver at 1..256 iterations, the impulse-space
// integrator at several tolerances) and, in the same run on the same contacts, the peers Bullet
// (sequential impulses at 1..256 iterations, MLCP Dantzig), ODE (dWorldStep, dWorldQuickStep
// at 1..256 iterations) and Simbody (one SemiExplicitEulerTimeStepper step: PLUS, and PGS at
// 1..256 iterations, each with Poisson and with Newton restitution). Writes one CSV row per
// (scene, method, setting).
//   accuracy_sweep [--out FILE] [--reps N] [--scenes NAME,NAME,...] [--calls N]
//                  [--peer CONFIG --peer-calls N]
// --scenes: only the named scenes (default: all). --calls N: no timing, no peers, no CSV: runs our
// newton_exact N times on each instance of the scenes (for callgrind: compare the instruction
// counts of two runs with different N; a --toggle-collect on solveIsland* would miss the inner
// solveIsland, which toggles collection off again). --peer CONFIG --peer-calls N: the same for a
// peer's contact-resolving step, N repetitions on each instance; CONFIG is bullet_si:ITERATIONS,
// bullet_mlcp_dantzig, ode_step or ode_quickstep:ITERATIONS (for callgrind: --toggle-collect on
// btSequentialImpulseConstraintSolver::solveGroup*, dWorldStep or dWorldQuickStep, whose
// instruction count divided by N x instances is the step's).
// Timing: steady_clock, warm cache, median over repetitions of a block of calls on pre-built
// inputs (ours: the solver call alone; peers: their contact-resolving step alone), averaged over
// the instances of a batch. Errors: bench_metrics.h, the largest over the instances.
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "bench_metrics.h"
#include "bench_scenes.h"
#include "collision_response/core/contact_point.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/impulse_space_integrator.h"
#include "collision_response/core/island_solver.h"
#include "collision_response/core/rigid_body.h"
#include "collision_response/core/single_contact.h"
#include "peer_run.h"
#ifdef HAVE_BULLET
#include "peer_bullet.h"
#endif
#ifdef HAVE_ODE
#include "peer_ode.h"
#endif
#ifdef HAVE_SIMBODY
#include "peer_simbody.h"
#endif

namespace bench = collision_response::bench;
namespace core = collision_response::core;
using Eigen::Vector3d;

namespace {

/// Keeps the compiler from discarding a result.
template <class T>
inline void keep(const T& value) {
  asm volatile("" : : "g"(&value) : "memory");
}

/// One scene instance prepared for the low-level solvers (outside the timed region).
struct Prepared {
  std::vector<core::RigidBody> bodies;
  std::vector<core::ContactPoint> rows;
  std::vector<int> island;
};

Prepared prepare(const core::Scene& scene) {
  Prepared p;
  for (const auto& b : scene.bodies) p.bodies.push_back(core::makeRigidBody(b));
  auto index = [&](const std::string& id) {
    for (std::size_t i = 0; i < scene.bodies.size(); ++i)
      if (scene.bodies[i].id == id) return static_cast<int>(i);
    return -1;
  };
  for (const auto& c : scene.contacts) {
    const int a = index(c.body_a), b = index(c.body_b);
    p.rows.emplace_back(a, b, c.point, c.normal, c.restitution, c.static_friction,
                        c.dynamic_friction);
    p.island.push_back(static_cast<int>(p.island.size()));
  }
  return p;
}

/// Answer of one of our methods on one instance: post velocities and per-contact impulses.
struct Answer {
  bench::Velocities after;
  std::vector<Vector3d> impulses;
  std::string note;
};

/// One of our methods: `solve` runs it once on a prepared instance into `work` (timed);
/// `answer` runs it once and reports (untimed).
struct OurMethod {
  std::string curve;
  std::string param;
  std::string reference_law;  ///< key of BenchScene::reference_by_law
  bool single_contact_only;
  std::function<void(const Prepared&, std::vector<core::RigidBody>& work,
                     std::vector<core::ContactImpulse>& impulses)>
      solve;
  /// Optional: work counts of one run on an instance (integrator: Taylor steps, segments).
  std::function<core::ImpulseSpaceDetail(const Prepared&)> stats = nullptr;
};

Answer answerOf(const OurMethod& m, const Prepared& p) {
  std::vector<core::RigidBody> work = p.bodies;
  std::vector<core::ContactImpulse> impulses(p.rows.size());
  m.solve(p, work, impulses);
  Answer a;
  for (const auto& b : work) {
    a.after.linear.push_back(b.linear_velocity);
    a.after.angular.push_back(b.angular_velocity);
  }
  for (std::size_t k = 0; k < p.rows.size(); ++k)
    a.impulses.push_back(impulses[k].total(p.rows[k].normal));
  return a;
}

/// Median over `reps` of the time of a block of calls, per call [ns].
double timePerCall(const OurMethod& m, const Prepared& p, int reps) {
  std::vector<core::RigidBody> work = p.bodies;
  std::vector<core::ContactImpulse> impulses(p.rows.size());
  auto block = [&](int calls) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < calls; ++i) {
      work = p.bodies;  // same size: no allocation
      m.solve(p, work, impulses);
      keep(work);
      keep(impulses);
    }
    const auto t1 = std::chrono::steady_clock::now();
    return std::chrono::duration<double, std::nano>(t1 - t0).count();
  };
  block(3);  // warm up
  const double once = std::max(block(1), 1.0);
  const int calls = static_cast<int>(std::clamp(50000.0 / once, 1.0, 5000.0));  // ~50 us blocks
  std::vector<double> times;
  for (int r = 0; r < reps; ++r) times.push_back(block(calls) / calls);
  std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
  return times[times.size() / 2];
}

std::vector<OurMethod> ourMethods() {
  using L = core::ImpactLaw;
  std::vector<OurMethod> out;
  for (const auto& [name, law] : {std::pair<const char*, L>{"newton_closed_form", L::kNewton},
                                  std::pair<const char*, L>{"seed_one_pass", L::kSeedOnePass}}) {
    const L l = law;
    out.push_back(
        {name, "", "newton", true,
         [l](const Prepared& p, std::vector<core::RigidBody>& work,
             std::vector<core::ContactImpulse>& impulses) {
           const auto& row = p.rows[0];
           impulses[0] = core::solveSingleContact(work[row.body_a], work[row.body_b], row, l);
           core::ContactSpace(work[row.body_a], work[row.body_b], row.point)
               .applyImpulse(work[row.body_a], work[row.body_b], impulses[0].total(row.normal));
         }});
  }
  for (const auto& [name, law] : {std::pair<const char*, L>{"poisson_integrator", L::kPoisson},
                                  std::pair<const char*, L>{"stronge_integrator", L::kStronge}}) {
    for (const int digits : {3, 6, 9, 12}) {
      const L l = law;
      const double tol = std::pow(10.0, -digits);
      out.push_back(
          {name, "tol=1e-" + std::to_string(digits), core::toString(l), true,
           [l, tol](const Prepared& p, std::vector<core::RigidBody>& work,
                    std::vector<core::ContactImpulse>& impulses) {
             const auto& row = p.rows[0];
             impulses[0] =
                 core::integrateSingleContact(work[row.body_a], work[row.body_b], row, l, tol);
             core::ContactSpace(work[row.body_a], work[row.body_b], row.point)
                 .applyImpulse(work[row.body_a], work[row.body_b], impulses[0].total(row.normal));
           },
           [l, tol](const Prepared& p) {
             core::ImpulseSpaceDetail stats;
             const auto& row = p.rows[0];
             core::integrateSingleContact(p.bodies[row.body_a], p.bodies[row.body_b], row, l, tol,
                                          &stats);
             return stats;
           }});
    }
  }
  auto island = [](L law, core::SolverMethod method, std::size_t iterations) {
    core::SolverOptions options;
    options.law = law;
    options.method = method;
    options.max_iterations = iterations;
    options.tolerance = 0.0;  // a fixed number of iterations
    options.time_budget = 3600.0;
    return [options](const Prepared& p, std::vector<core::RigidBody>& work,
                     std::vector<core::ContactImpulse>& impulses) {
      core::solveIsland(work, p.rows, p.island, options, impulses);
    };
  };
  out.push_back(
      {"newton_exact", "", "newton_lcp", false, island(L::kNewton, core::SolverMethod::kExact, 1)});
  for (int k = 1; k <= 256; k *= 2)
    out.push_back({"newton_iterative", "it=" + std::to_string(k), "newton_lcp", false,
                   island(L::kNewton, core::SolverMethod::kIterative, k)});
  // Several contacts: Poisson / Stronge as the automatic method solves them (the simultaneous
  // impulse-space integration up to 12 contacts, the default; beyond, the two-phase scheme on the
  // iterative solver), the two-phase schemes, and the one-pass law's sequential pass.
  for (const auto& [curve, law] :
       {std::pair<const char*, L>{"poisson_simultaneous", L::kPoisson},
        std::pair<const char*, L>{"stronge_simultaneous", L::kStronge}}) {
    core::SolverOptions options;
    options.law = law;
    options.time_budget = 3600.0;
    out.push_back({curve, "", law == L::kPoisson ? "poisson" : "stronge", false,
                   [options](const Prepared& p, std::vector<core::RigidBody>& work,
                             std::vector<core::ContactImpulse>& impulses) {
                     core::solveIsland(work, p.rows, p.island, options, impulses);
                   }});
  }
  out.push_back(
      {"poisson_exact", "", "poisson", false, island(L::kPoisson, core::SolverMethod::kExact, 1)});
  out.push_back(
      {"stronge_exact", "", "stronge", false, island(L::kStronge, core::SolverMethod::kExact, 1)});
  for (int k = 1; k <= 256; k *= 4)
    out.push_back({"stronge_iterative", "it=" + std::to_string(k), "stronge", false,
                   island(L::kStronge, core::SolverMethod::kIterative, k)});
  out.push_back({"seed_one_pass", "", "newton", false,
                 island(L::kSeedOnePass, core::SolverMethod::kExact, 1)});
  return out;
}

/// Velocity error of one answer against the references of the other laws (the largest over the
/// instances).
struct OtherLaws {
  double newton_lcp = 0.0, poisson = 0.0, stronge = 0.0;

  void accumulate(const bench::BenchScene& s, std::size_t instance, const bench::Velocities& after,
                  const std::vector<Vector3d>& impulses) {
    auto err = [&](const char* law) {
      return bench::measure(s.instances[instance], after, impulses, s.referenceFor(law)[instance])
          .velocity;
    };
    newton_lcp = std::max(newton_lcp, err("newton_lcp"));
    poisson = std::max(poisson, err("poisson"));
    stronge = std::max(stronge, err("stronge"));
  }
};

struct Writer {
  FILE* f;
  void header() {
    std::fprintf(
        f,
        "scene,family,reference,contacts,instances,engine,curve,param,law,expressible,"
        "ns_per_solve,ns_per_contact,vel_err,energy_err,energy_gain,restitution_err,"
        "approach,cone_violation,energy_ratio,vel_err_newton_lcp,vel_err_poisson,vel_err_stronge,"
        "note\n");
  }
  void row(const bench::BenchScene& s, const std::string& engine, const std::string& curve,
           const std::string& param, const std::string& law, const std::string& expressible,
           double ns, const bench::Errors& e, const OtherLaws& other, const std::string& note) {
    const double contacts = static_cast<double>(s.contactsPerInstance());
    std::fprintf(f,
                 "%s,%s,\"%s\",%zu,%zu,%s,%s,%s,%s,\"%s\",%.1f,%.2f,%.3e,%.3e,%.3e,%.3e,%.3e,%.3e,"
                 "%.6f,%.3e,%.3e,%.3e,\"%s\"\n",
                 s.name.c_str(), s.family.c_str(), s.reference.c_str(), s.contactsPerInstance(),
                 s.instances.size(), engine.c_str(), curve.c_str(), param.c_str(), law.c_str(),
                 expressible.c_str(), ns, ns / contacts, e.velocity, e.energy, e.energy_gain,
                 e.restitution, e.approach, e.cone, e.energy_ratio, other.newton_lcp, other.poisson,
                 other.stronge, note.c_str());
    std::fflush(f);
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::string out_path = "benchmark/results.csv";
  int reps = 15;
  int profile_calls = 0;
  int peer_calls = 0;
  std::string peer_config;
  std::string only;  // ",name,name," or empty for every scene
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) out_path = argv[++i];
    if (!std::strcmp(argv[i], "--reps") && i + 1 < argc) reps = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--scenes") && i + 1 < argc)
      only = "," + std::string(argv[++i]) + ",";
    if (!std::strcmp(argv[i], "--calls") && i + 1 < argc) profile_calls = std::atoi(argv[++i]);
    if (!std::strcmp(argv[i], "--peer") && i + 1 < argc) peer_config = argv[++i];
    if (!std::strcmp(argv[i], "--peer-calls") && i + 1 < argc) peer_calls = std::atoi(argv[++i]);
  }
  const auto selected = [&only](const std::string& name) {
    return only.empty() || only.find("," + name + ",") != std::string::npos;
  };
  if (profile_calls > 0) {
    const std::vector<OurMethod> methods = ourMethods();
    const auto exact = std::find_if(methods.begin(), methods.end(),
                                    [](const OurMethod& m) { return m.curve == "newton_exact"; });
    for (const auto& s : bench::makeScenes()) {
      if (!selected(s.name)) continue;
      for (const auto& inst : s.instances) {
        const Prepared p = prepare(inst);
        std::vector<core::RigidBody> work = p.bodies;
        std::vector<core::ContactImpulse> impulses(p.rows.size());
        for (int call = 0; call < profile_calls; ++call) {
          work = p.bodies;
          exact->solve(p, work, impulses);
          keep(work);
        }
      }
      std::fprintf(stderr, "accuracy_sweep: %s, newton_exact x %d\n", s.name.c_str(),
                   profile_calls);
    }
    return 0;
  }
  if (peer_calls > 0) {
    const std::size_t colon = peer_config.find(':');
    const std::string name = peer_config.substr(0, colon);
    [[maybe_unused]] const int iterations =
        colon == std::string::npos ? 10 : std::atoi(&peer_config[colon + 1]);
    for (const auto& s : bench::makeScenes()) {
      if (!selected(s.name)) continue;
      for ([[maybe_unused]] const auto& inst : s.instances) {
        bench::PeerRun run;
        if (false) {
#ifdef HAVE_BULLET
        } else if (name == "bullet_si") {
          run = bench::runBullet(inst, {bench::BulletSolver::kSequentialImpulse, iterations},
                                 peer_calls);
        } else if (name == "bullet_mlcp_dantzig") {
          run = bench::runBullet(inst, {bench::BulletSolver::kMlcpDantzig, 10}, peer_calls);
#endif
#ifdef HAVE_ODE
        } else if (name == "ode_step") {
          run = bench::runOde(inst, {bench::OdeStepper::kStep, 20}, peer_calls);
        } else if (name == "ode_quickstep") {
          run = bench::runOde(inst, {bench::OdeStepper::kQuickStep, iterations}, peer_calls);
#endif
        } else {
          std::fprintf(stderr, "accuracy_sweep: unknown or unavailable peer '%s'\n",
                       peer_config.c_str());
          return 1;
        }
        keep(run);
      }
      std::fprintf(stderr, "accuracy_sweep: %s, %s x %d per instance (%zu instances)\n",
                   s.name.c_str(), peer_config.c_str(), peer_calls, s.instances.size());
    }
    return 0;
  }
  FILE* f = std::fopen(out_path.c_str(), "w");
  if (!f) {
    std::perror(out_path.c_str());
    return 1;
  }
  Writer w{f};
  w.header();
  const std::vector<bench::BenchScene> scenes = bench::makeScenes();
  const std::vector<OurMethod> methods = ourMethods();
  for (const auto& s : scenes) {
    if (!selected(s.name)) continue;
    std::fprintf(stderr, "accuracy_sweep: %s (%zu contacts x %zu instances)\n", s.name.c_str(),
                 s.contactsPerInstance(), s.instances.size());
    std::vector<Prepared> prepared;
    for (const auto& inst : s.instances) prepared.push_back(prepare(inst));
    const bool single = s.contactsPerInstance() == 1;
    for (const auto& m : methods) {
      if (m.single_contact_only && !single) continue;
      if (single && (m.curve == "poisson_exact" || m.curve == "stronge_exact" ||
                     m.curve == "poisson_simultaneous" || m.curve == "stronge_simultaneous" ||
                     m.curve == "stronge_iterative" ||
                     (m.curve == "seed_one_pass" && !m.single_contact_only)))
        continue;  // one contact: the laws' own single-contact paths above
      bench::Errors total;
      OtherLaws other;
      double ns = 0.0, steps = 0.0, segments = 0.0;
      const auto& ref = s.referenceFor(m.reference_law);
      for (std::size_t i = 0; i < s.instances.size(); ++i) {
        const Answer a = answerOf(m, prepared[i]);
        bench::accumulate(total, bench::measure(s.instances[i], a.after, a.impulses, ref[i]));
        other.accumulate(s, i, a.after, a.impulses);
        ns += timePerCall(m, prepared[i], reps) / s.instances.size();
        if (m.stats) {
          const core::ImpulseSpaceDetail st = m.stats(prepared[i]);
          steps += static_cast<double>(st.steps) / s.instances.size();
          segments += static_cast<double>(st.segments) / s.instances.size();
        }
      }
      char note[96] = "";
      if (m.stats)
        std::snprintf(note, sizeof note, "mean %.1f Taylor steps, %.1f segments", steps, segments);
      w.row(s, "ours", m.curve, m.param, m.reference_law, "yes", ns, total, other, note);
    }
    const std::string expressible =
        s.friction_split ? "no: one friction coefficient (given mu_d)" : "yes";
    [[maybe_unused]] const int peer_reps = 2 * reps + 1;
    // A peer configuration, measured against the reference of `law` (Newton's restitution:
    // "newton_lcp"); `can_express`: what the "expressible" column says.
    auto peerOf = [&](const std::string& engine, const std::string& curve, const std::string& param,
                      const std::string& law, const std::string& can_express,
                      const std::function<bench::PeerRun(const core::Scene&)>& run) {
      bench::Errors total;
      OtherLaws other;
      double ns = 0.0;
      std::string note, skipped_why;
      std::size_t skipped = 0;
      const auto& ref = s.referenceFor(law);
      for (std::size_t i = 0; i < s.instances.size(); ++i) {
        const bench::PeerRun r = run(s.instances[i]);
        if (r.after.linear.empty()) {  // the peer cannot take this instance: r.note says why
          ++skipped;
          skipped_why = r.note;
          continue;
        }
        bench::accumulate(total, bench::measure(s.instances[i], r.after, r.impulses, ref[i]));
        other.accumulate(s, i, r.after, r.impulses);
        ns += r.ns_per_solve;
        if (!r.note.empty()) note = r.note;
      }
      const std::size_t ran = s.instances.size() - skipped;
      if (ran == 0) {  // no figures, only the reason
        const double nan = std::nan("");
        const bench::Errors none{nan, nan, nan, nan, nan, nan, nan};
        w.row(s, engine, curve, param, law, "no: " + skipped_why, nan, none, {nan, nan, nan},
              skipped_why);
        return;
      }
      if (skipped > 0)
        note = std::to_string(skipped) + " of " + std::to_string(s.instances.size()) +
               " instances not run (" +
               skipped_why.substr(skipped_why.rfind("not run: ", 0) == 0 ? 9 : 0) +
               "); figures over the other " + std::to_string(ran) +
               (note.empty() ? "" : "; " + note);
      w.row(s, engine, curve, param, law, can_express, ns / ran, total, other, note);
    };
    [[maybe_unused]] auto peer = [&](const std::string& engine, const std::string& curve,
                                     const std::string& param,
                                     const std::function<bench::PeerRun(const core::Scene&)>& run) {
      peerOf(engine, curve, param, "newton_lcp", expressible, run);
    };
#ifdef HAVE_BULLET
    for (int k = 1; k <= 256; k *= 2)
      peer("bullet", "bullet_si", "it=" + std::to_string(k), [&](const core::Scene& scene) {
        return bench::runBullet(scene, {bench::BulletSolver::kSequentialImpulse, k}, peer_reps);
      });
    peer("bullet", "bullet_mlcp_dantzig", "", [&](const core::Scene& scene) {
      return bench::runBullet(scene, {bench::BulletSolver::kMlcpDantzig, 10}, peer_reps);
    });
#endif
#ifdef HAVE_ODE
    peer("ode", "ode_step", "", [&](const core::Scene& scene) {
      return bench::runOde(scene, {bench::OdeStepper::kStep, 20}, peer_reps);
    });
    for (int k = 1; k <= 256; k *= 2)
      peer("ode", "ode_quickstep", "it=" + std::to_string(k), [&](const core::Scene& scene) {
        return bench::runOde(scene, {bench::OdeStepper::kQuickStep, k}, peer_reps);
      });
#endif
#ifdef HAVE_SIMBODY
    // Simbody has mu_s and mu_d (chosen once from the slip before the impact) and Poisson's or
    // Newton's restitution: each measured against our reference of that law. PLUS at the
    // constraint tolerance 1e-10 and at Simbody's default 1e-3 (its rolling and capture speeds
    // are twice it); PGS at 1e-10.
    using SR = bench::SimbodyRestitution;
    using SS = bench::SimbodySolver;
    for (const auto& [name, restitution, law] :
         {std::tuple<const char*, SR, const char*>{"poisson", SR::kPoisson, "poisson"},
          std::tuple<const char*, SR, const char*>{"newton", SR::kNewton, "newton_lcp"}}) {
      const SR rest = restitution;
      for (const auto& [ctol_name, ctol] :
           {std::pair<const char*, double>{"ctol=1e-10", 1e-10}, {"ctol=1e-3", 1e-3}}) {
        const double c = ctol;
        peerOf("simbody", std::string("simbody_plus_") + name, ctol_name, law, "yes",
               [&](const core::Scene& scene) {
                 return bench::runSimbody(scene, {SS::kPlus, rest, 0, -1.0, c}, peer_reps);
               });
      }
      for (int k = 1; k <= 256; k *= 4)
        peerOf("simbody", std::string("simbody_pgs_") + name, "it=" + std::to_string(k), law, "yes",
               [&](const core::Scene& scene) {
                 return bench::runSimbody(scene, {SS::kPgs, rest, k, 0.0}, peer_reps);
               });
    }
#endif
  }
  std::fclose(f);
  std::fprintf(stderr, "accuracy_sweep: wrote %s\n", out_path.c_str());
  return 0;
}
