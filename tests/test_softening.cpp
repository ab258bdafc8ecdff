// Softening links (MaterialDef::fracture_energy) and links' own strengths (MaterialDef::weibull_modulus):
// the law dissipates the fracture energy, a pulled bar absorbs G_f per unit of crack area at every
// spacing, the strengths spread as a Weibull distribution of mean 1, and every instruction set, thread
// count and resumed run computes the same bits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numeric>
#include <set>
#include <tbb/global_control.h>

#include "io/checkpoint.hpp"
#include "io/scene_io.hpp"
#include "lattice/heterogeneity.hpp"
#include "physics/fracture.hpp"
#include "bitwise.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

// One link in uniaxial tension, taken through its softening in small strain increments: the stress is
// keep * E * eps, and its integral over the elongation is the energy per unit cross-section, G_f.
TEST(Softening, TheLawDissipatesTheFractureEnergyOfALink) {
  for (const double r0 : {0.05, 0.01, 0.002}) {
    const float E = 30e9f, f = 3e6f, gf = 100.0f;
    const float soft = softening_constant(gf, gf, E, E, static_cast<float>(r0));
    const double eps0 = f / E;
    double energy = 0, last_sigma = 0;
    float damage = 0;
    bool broken = false;
    const double de = eps0 / 2000;
    double eps = 0;
    for (int k = 0; k < 10000000 && !broken; ++k) {
      eps += de;
      const float sigma = static_cast<float>(E * eps);  // the undamaged stress, all of it the pair's
      const SofteningTest<float> t = link_softening_test<float, float>(
          static_cast<float>(eps * r0), static_cast<float>(r0), sigma, 0.0f, 0.0f, f, 1.0f, 1.0f, 1.0f, soft, damage);
      damage = t.damage;
      broken = t.stress || t.displacement;
      const double s = (1.0 - damage) * sigma;
      energy += 0.5 * (s + last_sigma) * de * r0;  // trapezoid, per unit cross-section
      last_sigma = s;
      if (!broken) {
        EXPECT_LE(s, f * 1.0001) << "the stress passed the strength at eps " << eps;
      }
    }
    ASSERT_TRUE(broken);
    std::printf("r0 %.3g m: %.2f J/m^2 dissipated (G_f %.0f), broke at %.1f x the strength's strain\n", r0, energy, gf,
                eps / eps0);
    EXPECT_NEAR(energy / gf, 1.0, 0.01) << "r0 " << r0;
  }
}

// A fracture energy too small for the link's length (the law would snap back): the link breaks at its
// strength, as without softening.
TEST(Softening, AFractureEnergyTooSmallForTheLinkBreaksItAtItsStrength) {
  const float E = 30e9f, f = 3e6f;
  const float soft = softening_constant(0.1f, 0.1f, E, E, 0.05f);  // ku = 2 G_f E / (f^2 r0) = 0.013
  const auto below = link_softening_test<float, float>(0.0f, 0.05f, 0.99f * f, 0.0f, 0.0f, f, 1.0f, 1.0f, 1.0f, soft, 0.0f);
  EXPECT_FALSE(below.stress);
  EXPECT_EQ(below.damage, 0.0f);
  const auto at = link_softening_test<float, float>(0.0f, 0.05f, f, 0.0f, 0.0f, f, 1.0f, 1.0f, 1.0f, soft, 0.0f);
  EXPECT_TRUE(at.stress);
  EXPECT_EQ(at.damage, 1.0f);
  // An end without a fracture energy makes the pair's law the instant one.
  EXPECT_EQ(softening_constant(100.0f, 0.0f, E, E, 0.05f), 0.0f);
}

// Unloading keeps the damage: a link loaded to twice its strength's effort and let go keeps its damage;
// the force keeps its undamaged share of a tensile stress and of the shear spring, and carries compression
// whole.
TEST(Softening, UnloadingKeepsTheDamageAndCompressionIsCarried) {
  const float E = 30e9f, f = 3e6f, r0 = 0.05f;
  const float soft = softening_constant(100.0f, 100.0f, E, E, r0);
  const auto peak = link_softening_test<float, float>(0.0f, r0, 2 * f, 0.0f, 0.0f, f, 1.0f, 1.0f, 1.0f, soft, 0.0f);
  EXPECT_GT(peak.damage, 0.5f);
  EXPECT_LT(peak.damage, 1.0f);
  EXPECT_FALSE(peak.stress);
  const auto later = link_softening_test<float, float>(0.0f, r0, 0.5f * f, 0.0f, 0.0f, f, 1.0f, 1.0f, 1.0f, soft, peak.damage);
  EXPECT_EQ(later.damage, peak.damage);
  LinkInputT<float> in{};
  in.g.n = {1, 0, 0};
  in.area = r0 * r0;
  in.kt = 1e6f;
  LinkOutputT<float> o{};
  o.ut = {0, 1e-6f, 0};
  in.g.eps = -1e-4f;  // a compressed link
  o.sigma = -1e6f;
  const Vec3 fc = softened_force(in, o, 0.75f);
  EXPECT_FLOAT_EQ(fc.x, -1e6f * in.area) << "compression is carried whole";
  EXPECT_FLOAT_EQ(fc.y, 0.25f * 1e6f * 1e-6f) << "the shear spring keeps its share";
  o.sigma = 2e5f;  // compressed, in tension through its ends' many-body terms: still closed, carried whole
  EXPECT_FLOAT_EQ(softened_force(in, o, 0.75f).x, 2e5f * in.area);
  in.g.eps = 1e-4f;  // stretched: open
  o.sigma = 1e6f;
  EXPECT_FLOAT_EQ(softened_force(in, o, 0.75f).x, 0.25f * 1e6f * in.area) << "tension keeps its share";
  o.sigma = -2e5f;  // stretched, in compression through the many-body terms: the open crack carries its share
  EXPECT_FLOAT_EQ(softened_force(in, o, 0.75f).x, 0.25f * -2e5f * in.area);
}

// A bar pulled apart slowly, one automaton thick, held at one end: once it has come apart, the pulling
// grip's work is the energy the broken section took, G_f d^2, plus what the bar held at the peak
// (sigma_t^2 / (2 E) over its 5 d of length: 4 % of G_f d^2 at d = 1 cm, 2 % at 5 mm), what the links
// that began to soften and then unloaded took, and the dashpots' share. Per unit of crack area that is
// G_f whatever the spacing; with the instant break it is sigma_t^2 d n / (2 E), and it falls with the
// spacing.
struct Pulled {
  double work = 0;         // of the pulling grip [J]
  std::int64_t broken = 0;
};

Pulled pull_apart(double d, double fracture_energy, double jitter = 0) {
  const int n = 6;  // short: the bar's elastic energy at the peak stays below what the softening link takes
  MaterialDef mat = test::test_material();
  mat.tensile_strength = 3e6;
  mat.compressive_strength = 3e6;
  mat.fracture_strain = 1.5e-4;
  mat.fracture_energy = fracture_energy;
  SceneDef sc = test::pulled_bar(n, d, mat);
  sc.solver.lattice_jitter = jitter;
  for (GripDef& g : sc.grips) {  // the jittered sites of the end cells
    g.min[0] -= 0.3 * d;
    g.max[0] += 0.3 * d;
  }
  Engine sim(sc);
  EXPECT_EQ(sim.state().link_damage.empty(), fracture_energy == 0);
  // Until a link breaks, then 20,000 steps on (the parts apart, the pulled end's force zero).
  std::int64_t broke_at = -1;
  for (int k = 0; k < 200000; ++k) {
    if (sim.advance(100).flags != kHealthy) {
      ADD_FAILURE() << "the run stopped at step " << sim.state().step;
      return {};
    }
    const State& s = sim.state();
    if (broke_at < 0 && s.broken_by[0] + s.broken_by[1] > 0) broke_at = s.step;
    if (broke_at >= 0 && s.step > broke_at + 20000) break;
  }
  EXPECT_GE(broke_at, 0) << "the bar did not break";
  EXPECT_NEAR(sim.state().grip_force[1].x, 0.0, 1e-3) << "the parts are apart";
  return {sim.state().grip_work[1], sim.state().broken_by[0] + sim.state().broken_by[1]};
}

TEST(Softening, ABarPulledApartTakesTheFractureEnergyPerAreaAtEverySpacing) {
  const double gf = 100;
  double per_area[2] = {};
  int k = 0;
  for (const double d : {0.01, 0.005}) {
    const Pulled soft = pull_apart(d, gf), instant = pull_apart(d, 0);
    per_area[k++] = soft.work / (d * d);
    std::printf("d = %.3g m: %.1f J/m^2 and %lld broken link(s) with G_f = %.0f; %.2f J/m^2 and %lld with the "
                "instant break (sigma_t^2 5 d / 2E = %.2f)\n",
                d, soft.work / (d * d), static_cast<long long>(soft.broken), gf, instant.work / (d * d),
                static_cast<long long>(instant.broken), 3e6 * 3e6 * 5 * d / (2 * 30e9));
    EXPECT_EQ(soft.broken, 1) << "the softening bar breaks once";
    EXPECT_GE(soft.work / (d * d), gf) << "d " << d;
    EXPECT_LE(soft.work / (d * d), 1.3 * gf) << "d " << d;
    EXPECT_LT(instant.work / (d * d), 0.1 * gf) << "d " << d;
  }
  EXPECT_NEAR(per_area[1] / per_area[0], 1.0, 0.03) << "the same energy per crack area at both spacings";
  // On the jittered lattice each link takes G_f over its own cross-section too (its own length and the
  // lattice's stiffness factor in the softening's end).
  const Pulled jittered = pull_apart(0.01, gf, 0.25);
  std::printf("jittered, d = 1 cm: %.1f J/m^2 and %lld broken link(s)\n", jittered.work / 1e-4,
              static_cast<long long>(jittered.broken));
  EXPECT_EQ(jittered.broken, 1);
  EXPECT_GE(jittered.work / 1e-4, gf);
  EXPECT_LE(jittered.work / 1e-4, 1.3 * gf);
}

// Weibull factors: mean 1 and the coefficient of variation of modulus m, sqrt(G(1 + 2/m) / G(1 + 1/m)^2 - 1).
TEST(LinkStrength, WeibullFactorsHaveMeanOneAndTheModulusSpread) {
  for (const double m : {3.0, 6.0, 12.0}) {
    double sum = 0, sum2 = 0;
    const int N = 200000;
    for (int k = 0; k < N; ++k) {
      const double w = lattice::weibull_factor((k + 0.5) / N, m);
      sum += w;
      sum2 += w * w;
    }
    const double mean = sum / N, cv = std::sqrt(sum2 / N - mean * mean) / mean;
    const double g1 = std::tgamma(1 + 1 / m), g2 = std::tgamma(1 + 2 / m);
    EXPECT_NEAR(mean, 1.0, 0.002) << "m " << m;
    EXPECT_NEAR(cv, std::sqrt(g2 / (g1 * g1) - 1), 0.003) << "m " << m;
  }
  EXPECT_FLOAT_EQ(lattice::weibull_factor(0.0, 1.0), static_cast<float>(lattice::kMinLinkStrength));
}

// The default scene with the ball 5 mm from the wall, of the materials' spread and fracture energy.
SceneDef spread_wall(double weibull, double gf) {
  SceneDef s = test::struck_default_wall();
  for (MaterialDef& m : s.materials) {
    m.weibull_modulus = weibull;
    m.fracture_energy = gf;
  }
  if (s.materials.empty()) {
    MaterialDef c = *find_builtin_material("concrete");
    c.weibull_modulus = weibull;
    c.fracture_energy = gf;
    s.materials.push_back(c);
  }
  return s;
}

TEST(LinkStrength, EachLinkDrawsItsOwnFactorFromTheSeed) {
  Engine a(spread_wall(6, 0));
  const Model& m = a.model();
  ASSERT_EQ(m.link_strength.size(), m.lattice_slots());
  double sum = 0;
  std::size_t links = 0, differ = 0;
  for (std::size_t l = 0; l < m.lattice_slots(); ++l) {
    if (m.neighbour[l] == Model::kNoLink) {
      EXPECT_EQ(m.link_strength[l], 1.0f);
      continue;
    }
    sum += m.link_strength[l];
    ++links;
  }
  EXPECT_NEAR(sum / static_cast<double>(links), 1.0, 0.01);
  SceneDef other = spread_wall(6, 0);
  other.solver.seed = 2;
  Engine b(other);
  for (std::size_t l = 0; l < m.lattice_slots(); ++l) differ += m.link_strength[l] != b.model().link_strength[l];
  EXPECT_GT(differ, links / 2) << "another seed draws other factors";
  Engine c(spread_wall(6, 0));
  EXPECT_EQ(c.model().link_strength, m.link_strength) << "the same seed draws the same";
  Engine none(spread_wall(0, 0));
  EXPECT_TRUE(none.model().link_strength.empty());
}

// On the random lattice the explicit links draw their own factors (keyed by slot, as the lattice's).
TEST(LinkStrength, TheRandomLatticesLinksDrawTheirOwn) {
  SceneDef s = spread_wall(6, 0);
  s.solver.lattice = SolverDef::Lattice::random;
  Engine a(s);
  const Model& m = a.model();
  ASSERT_EQ(m.link_strength.size(), m.link_slots());
  double sum = 0, sum2 = 0;
  for (std::size_t l = m.lattice_slots(); l < m.link_slots(); ++l) {
    sum += m.link_strength[l];
    sum2 += static_cast<double>(m.link_strength[l]) * m.link_strength[l];
  }
  const double k = static_cast<double>(m.explicit_links.size()), mean = sum / k;
  const double cv = std::sqrt(sum2 / k - mean * mean) / mean;
  std::printf("random wall, weibull_modulus 6: %zu links, mean factor %.4f, coefficient of variation %.4f\n",
              m.explicit_links.size(), mean, cv);
  EXPECT_GT(k, 20000);
  EXPECT_NEAR(mean, 1.0, 0.01);
  EXPECT_NEAR(cv, 0.19, 0.01);  // sqrt(Gamma(1 + 2/6) / Gamma(1 + 1/6)^2 - 1) = 0.188
  s.solver.seed = 2;
  EXPECT_NE(Engine(s).model().link_strength, m.link_strength) << "another seed draws other factors";
}

// Softening and spread strengths on the default wall: every instruction set and thread count gives the
// same state, the sweep the bits of one pass at a time, and a run resumed from a checkpoint the bits of
// one that went straight through.
TEST(Softening, EveryInstructionSetThreadCountAndResumeGivesTheSameState) {
  const test::Bitwise r = test::expect_bitwise_everywhere(spread_wall(6, 100), 3000, [](const State& at) {
    bool softened = false;
    for (float k : at.link_damage) softened = softened || (k > 0.0f && k < 1.0f);
    EXPECT_TRUE(softened) << "some link softens before the checkpoint";
  });
  EXPECT_GT(r.broken, 0);
}

// The same on the random lattice, whose explicit links soften and spread their strengths too.
TEST(Softening, OnTheRandomLatticeEveryInstructionSetThreadCountAndResumeGivesTheSameState) {
  SceneDef s = spread_wall(6, 100);
  s.solver.lattice = SolverDef::Lattice::random;
  const test::Bitwise r = test::expect_bitwise_everywhere(s, 1500, [](const State& at) {
    std::size_t softened = 0;
    for (float k : at.link_damage) softened += k > 0.0f && k < 1.0f;
    EXPECT_GT(softened, 0u) << "some link softens before the checkpoint";
  });
  EXPECT_GT(r.broken, 0);
}

// A block pulled apart slowly (test::block_fracture_work), the pull's work per unit of its section. The
// cubic lattice's: about G_f (138.7 J/m^2 at G_f = 100: one section breaks, 36 links, and the sections
// next to both grips soften part way). The random lattice's: 2.6 G_f (257.0 J/m^2, 130 broken links):
// its links are loaded unevenly (links inclined to the pull, sites off their cells' centres), so links
// all over the block reach their strength and soften before one crack takes the load, as with the instant
// break, where 243 links break for a section of 36 cubic ones. That energy is the lattice's, spent ahead
// of the crack: a coarser view of concrete's process zone, measured here, not calibrated away. History:
// 321.0 J/m^2 (instant break 22.5) until a broken link's pair touched at its initial distance
// (Model::contact_reach); 346.5 (127.8) until the random links were held to their own stresses
// (random_link_effort, 2026-12-02: the equivalent stress broke them by shear from a tenth of the
// compressive strength; the changes are not split by term); 241.8 (23.1) until its ghosts were mirrored
// and its strength factor lowered to 1.078 (2026-12-03).
TEST(Softening, ABlockPulledApartTakesTheFractureEnergyPerAreaOnEitherLattice) {
  const double gf = 100;
  const auto cubic = [](SceneDef&) {};
  const auto random = [](SceneDef& sc) { sc.solver.lattice = SolverDef::Lattice::random; };
  const test::FractureWork c = test::block_fracture_work(cubic, 0, gf);
  const test::FractureWork r = test::block_fracture_work(random, 0.2499 * 0.01, gf);
  const test::FractureWork r0 = test::block_fracture_work(random, 0.2499 * 0.01, 0);
  std::printf("6 x 6 block pulled apart, G_f = %.0f J/m^2: cubic %.1f J/m^2 (%lld broken links), random %.1f J/m^2 "
              "(%lld); random with the instant break %.1f J/m^2 (%lld)\n",
              gf, c.per_area, static_cast<long long>(c.broken), r.per_area, static_cast<long long>(r.broken),
              r0.per_area, static_cast<long long>(r0.broken));
  EXPECT_GE(c.per_area, gf);
  EXPECT_LE(c.per_area, 1.5 * gf);
  EXPECT_EQ(c.broken, 36) << "one section";
  EXPECT_NEAR(r.per_area / gf, 2.57, 0.25);  // as measured: a change is seen
  EXPECT_NEAR(r0.per_area / gf, 0.203, 0.05);
}

// A damaged link stretches far beyond a sound one while it stays intact (up to ku times the strength's
// strain), so the contact search must not take its ends to be boxed in by their neighbours: with a
// fracture energy so large that nothing breaks, the struck wall's automata passed through each other
// (pairs 6 mm apart at d = 5 cm, found by the hostile review) until damaged links counted as open.
// (On the random lattice the same: its explicit links' ends count as exposed once a link is damaged.)
TEST(Softening, AutomataOfDamagedLinksAreSeenByTheContactSearch) {
  for (const bool random : {false, true}) {
    SCOPED_TRACE(random ? "random lattice" : "cubic lattice");
    SceneDef s = spread_wall(0, 1e6);
    s.projectiles[0].velocity = {0, 120, 0};
    if (random) s.solver.lattice = SolverDef::Lattice::random;
    Engine sim(s);
    const Model& m = sim.model();
    // The pairs some link joins (broken or not), and the closest pair no link joins.
    std::set<std::pair<std::uint32_t, std::uint32_t>> linked;
    m.for_each_link([&](std::size_t, std::uint32_t i, std::uint32_t j, int) { linked.insert({std::min(i, j), std::max(i, j)}); });
    const auto closest_unlinked = [&](const State& st) {
      double closest = 1e9;
      for (std::uint32_t i = 0; i < m.size(); ++i)
        for (std::uint32_t j = i + 1; j < m.size(); ++j) {
          const DVec3 d = ddelta(st.x[i], st.x[j]);
          const double r2 = dot(d, d);
          if (r2 < closest * closest && !linked.count({i, j})) closest = std::sqrt(r2);
        }
      return closest;
    };
    const double at_start = closest_unlinked(sim.state());
    ASSERT_EQ(sim.advance(random ? 6000 : 3000).flags, kHealthy);
    const State& st = sim.state();
    EXPECT_EQ(st.broken_by[0] + st.broken_by[1], 0) << "nothing breaks at G_f = 1e6";
    std::size_t damaged = 0;
    for (float d : st.link_damage) damaged += d > 0;
    EXPECT_GT(damaged, 100u);
    const double closest = closest_unlinked(st);
    std::printf("%s lattice: closest unlinked pair %.4f m (%.4f m at the start, d = %.3f m), %zu damaged links\n",
                random ? "random" : "cubic", closest, at_start, m.spacing, damaged);
    EXPECT_GT(closest, 0.7 * std::min(at_start, static_cast<double>(m.spacing)));
  }
}

TEST(Softening, SceneKeysRoundTripAndOutOfRangeValuesAreRefused) {
  SceneDef s = io::parse_scene(
      "[[material]]\nname = \"c\"\nbase = \"concrete\"\nfracture_energy = 120\nweibull_modulus = 5\n"
      "[[object]]\nname = \"o\"\nmaterial = \"c\"\nsize = [0.2, 0.2, 0.2]\n",
      "keys.toml");
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].fracture_energy, 120);
  EXPECT_EQ(s.materials[0].weibull_modulus, 5);
  const SceneDef back = io::parse_scene(io::scene_to_toml(s), "back.toml");
  EXPECT_EQ(back.materials[0].fracture_energy, 120);
  EXPECT_EQ(back.materials[0].weibull_modulus, 5);
  for (const char* bad : {"fracture_energy = -1", "fracture_energy = 2e6", "weibull_modulus = 0.5",
                          "weibull_modulus = -3", "weibull_modulus = 101", "fracture_energy = nan"}) {
    const std::string text = std::string("[[material]]\nname = \"c\"\nbase = \"concrete\"\n") + bad +
                             "\n[[object]]\nname = \"o\"\nmaterial = \"c\"\nsize = [0.2, 0.2, 0.2]\n";
    const std::string e = test::error_of([&] { validate_scene(io::parse_scene(text, "bad.toml")); });
    SCOPED_TRACE(bad);
    EXPECT_NE(e.find(std::string(bad).substr(0, std::string(bad).find(' '))), std::string::npos) << e;
    EXPECT_NE(e.find("bad.toml"), std::string::npos) << e;
  }
}

}  // namespace
}  // namespace mca
