// Built-in materials and the paper's heterogeneity presets.
#include <mca/scene.hpp>

namespace mca {

namespace {

// Room-temperature handbook values (Ashby & Jones, "Engineering Materials 1", 4th ed., tables 3.1,
// 8.1 and 15.x; CRC Handbook of Chemistry and Physics; Eurocode 2 for concrete C25/30). Brittle tensile
// strengths are the low end of the quoted ranges, since the simulator's strongest class carries the
// full value and heterogeneity weakens from there.
//
// fracture_strain is 1.5 x tensile_strength / E for the brittle materials: in slow tension the stress
// criterion then governs, and the displacement criterion only catches links that are torn open fast
// (physics.md section 4). Steel's is its elongation at break, so it deforms rather than shatters.
//
// friction is the dry Coulomb coefficient of the material on itself (on concrete for steel);
// restitution is that of a sphere impact at a few m/s.
std::vector<MaterialDef> make_builtins() {
  std::vector<MaterialDef> m;
  {
    MaterialDef d;
    d.name = "concrete";  // normal-weight concrete, about C25/30
    d.youngs_modulus = 30e9;
    d.poisson_ratio = 0.2;
    d.density = 2400.0;
    d.tensile_strength = 3.0e6;
    d.compressive_strength = 30e6;
    d.fracture_strain = 1.5e-4;
    d.friction = 0.6;
    d.restitution = 0.2;
    m.push_back(d);
  }
  {
    MaterialDef d;
    d.name = "glass";  // soda-lime glass; tensile strength is that of an annealed, handled surface
    d.youngs_modulus = 70e9;
    d.poisson_ratio = 0.22;
    d.density = 2500.0;
    d.tensile_strength = 50e6;
    d.compressive_strength = 1000e6;
    d.fracture_strain = 1.5 * 50e6 / 70e9;
    d.friction = 0.4;
    d.restitution = 0.7;
    m.push_back(d);
  }
  {
    MaterialDef d;
    d.name = "ceramic";  // dense alumina (Al2O3, 96-99.5 %)
    d.youngs_modulus = 300e9;
    d.poisson_ratio = 0.22;
    d.density = 3900.0;
    d.tensile_strength = 250e6;
    d.compressive_strength = 2500e6;
    d.fracture_strain = 1.5 * 250e6 / 300e9;
    d.friction = 0.4;
    d.restitution = 0.6;
    m.push_back(d);
  }
  {
    MaterialDef d;
    d.name = "granite";
    d.youngs_modulus = 50e9;
    d.poisson_ratio = 0.25;
    d.density = 2700.0;
    d.tensile_strength = 10e6;
    d.compressive_strength = 120e6;
    d.fracture_strain = 1.5 * 10e6 / 50e9;
    d.friction = 0.6;
    d.restitution = 0.3;
    m.push_back(d);
  }
  {
    MaterialDef d;
    d.name = "steel";  // structural carbon steel; tension = compression strength (von Mises)
    d.youngs_modulus = 200e9;
    d.poisson_ratio = 0.3;
    d.density = 7850.0;
    d.tensile_strength = 400e6;
    d.compressive_strength = 400e6;
    d.fracture_strain = 0.2;
    d.friction = 0.4;
    d.restitution = 0.6;
    m.push_back(d);
  }
  return m;
}

}  // namespace

const std::vector<MaterialDef>& builtin_materials() {
  static const std::vector<MaterialDef> materials = make_builtins();
  return materials;
}

const MaterialDef* find_builtin_material(const std::string& name) {
  for (const MaterialDef& m : builtin_materials()) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

bool heterogeneity_preset(const std::string& name, std::array<double, 4>& shares) {
  // Paper section 5.1; class 1 is the weakest.
  if (name == "none") {
    shares = {0.0, 0.0, 0.0, 1.0};
  } else if (name == "low") {
    shares = {0.0, 0.0, 0.10, 0.90};
  } else if (name == "medium") {
    shares = {0.0, 0.15, 0.20, 0.65};
  } else if (name == "high") {
    shares = {0.20, 0.25, 0.25, 0.30};
  } else {
    return false;
  }
  return true;
}

}  // namespace mca
