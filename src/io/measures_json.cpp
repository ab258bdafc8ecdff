#include "io/measures_json.hpp"

#include <fmt/format.h>

#include <optional>
#include <string>

namespace mca::io {

namespace {
nlohmann::json value_or_null(const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); }

// j[key] = v, and when v is unset j[reason_key] = why.
void put(nlohmann::json& j, const char* key, const std::optional<double>& v, const char* reason_key,
         const std::string& why) {
  j[key] = value_or_null(v);
  if (!v) j[reason_key] = why;
}

nlohmann::json fragment_class(const analysis::FragmentClass& c) {
  return {{"count", c.count}, {"mass_share", c.mass_share}};
}

constexpr const char* kAxisName[] = {"x", "y", "z"};
}  // namespace

nlohmann::json mass_distribution_json(const analysis::MassDistribution& d) {
  nlohmann::json j;
  j["automata"] = d.automata;
  j["fragments"] = d.fragments;
  if (!d.reason.empty()) {
    j["reason"] = d.reason;
    return j;
  }
  const double unit = d.automaton_mass;
  j["mass"] = d.mass;
  j["automaton_mass"] = unit;
  nlohmann::json bins = nlohmann::json::array();
  for (const auto& b : d.bins)
    bins.push_back({{"automata_min", b.automata_min},
                    {"automata_max", b.automata_max},
                    {"count", b.count},
                    {"number_density", b.number_density},
                    {"abscissa_automata", b.abscissa},
                    {"abscissa_kg", b.abscissa * unit},
                    {"mass_share", b.mass_share}});
  j["bins"] = bins;
  j["singles"] = fragment_class(d.singles);
  j["fragments_2_to_9"] = fragment_class(d.small);
  auto mid = fragment_class(d.mid);
  mid["automata_min"] = 10;
  mid["automata_max"] = d.tenth;
  if (d.tenth < 10)
    mid["note"] = fmt::format("a tenth of the {} automata is below 10: no fragment can lie in this class", d.automata);
  j["fragments_10_to_tenth"] = mid;
  j["fragments_above_tenth"] = fragment_class(d.above_tenth);
  j["largest"] = {{"automata", d.largest_automata}, {"mass_share", d.largest_mass_share}};

  const analysis::PowerLawFit& f = d.fit;
  nlohmann::json fit;
  fit["fit_max_automata"] = f.fit_max_automata;
  fit["bins_in_range"] = f.bins_in_range;
  fit["bins_fitted"] = f.bins_fitted;
  fit["empty_bins_in_range"] = f.empty_bins_in_range;
  put(fit, "tau", f.tau, "reason", f.reason);
  if (f.tau) {
    put(fit, "tau_stderr", f.tau_stderr, "tau_stderr_reason", f.tau_stderr_reason);
    put(fit, "r2", f.r2, "r2_reason", f.r2_reason);
    fit["log10_prefactor"] = *f.log10_prefactor;
    fit["range_automata"] = {*f.m_first, *f.m_last};
    fit["range_kg"] = {*f.m_first * unit, *f.m_last * unit};
  } else {
    fit["tau_stderr"] = nullptr;
    fit["r2"] = nullptr;
    fit["log10_prefactor"] = nullptr;
    fit["range_automata"] = nullptr;
    fit["range_kg"] = nullptr;
  }
  fit["decades"] = f.tau ? nlohmann::json(f.decades) : nlohmann::json(nullptr);
  j["power_law"] = fit;
  return j;
}

nlohmann::json crack_isotropy_json(const analysis::CrackIsotropy& c) {
  nlohmann::json j;
  if (!c.reason.empty()) {
    j["reason"] = c.reason;
    return j;
  }
  const auto [a, b] = c.plane.axes();
  const analysis::SectorShares& s = c.sectors;
  j["normal"] = kAxisName[c.plane.normal];
  j["plane_axes"] = {kAxisName[a], kAxisName[b]};
  j["centre"] = c.plane.centre;
  j["half_width"] = c.half_width;
  j["radii_scaled"] = c.radii_scaled;
  j["r_in"] = s.r_in;
  j["r_out"] = s.r_out;
  j["threshold"] = s.threshold;
  std::string note;
  const auto add = [&note](const char* text) { note += (note.empty() ? "" : "; ") + std::string(text); };
  if (c.object_rotated) add("the first object is rotated: the sectors are centred on the world's axes, not its lattice's");
  if (c.no_link_broken)
    add("no link of the first object has broken: the damage counted is its softening links' alone, not cracks");
  if (c.saturated)
    add("every sector's share is at least 0.95: the annulus is damaged all round (softened links count), and the "
        "ratio says little of the cracks' directions");
  if (!note.empty()) j["note"] = note;
  j["automata_in_annulus"] = s.in_annulus;
  j["sector_angles_deg"] = {0, 45, 90, 135, 180, 225, 270, 315};
  j["sector_automata"] = s.automata;
  j["sector_damaged"] = s.damaged;
  nlohmann::json shares = nlohmann::json::array();
  for (const auto& v : s.share) shares.push_back(value_or_null(v));
  j["sector_shares"] = shares;
  j["axis_mean"] = value_or_null(s.axis_mean);
  j["diagonal_mean"] = value_or_null(s.diagonal_mean);
  j["axis_diagonal_ratio"] = value_or_null(s.ratio);
  if (!s.ratio) j["reason"] = s.reason;
  return j;
}

}  // namespace mca::io
