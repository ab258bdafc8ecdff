#pragma once
// Plain definition structs with defaults (one place validates them: validate_scene). The TOML reader
// fills them; C++ users may fill them directly. Units are SI throughout; angles in degrees.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace mca {

using Vec3d = std::array<double, 3>;

enum class StrengtheningLaw { none, exponential, quadratic };  // paper eq. 7

struct MaterialDef {
  std::string name = "concrete";
  double youngs_modulus = 30e9;         // E [Pa], > 0
  double poisson_ratio = 0.2;           // nu, in (-1, 0.5)
  static constexpr double kMinDensity = 0.1, kMaxDensity = 1e5;  // [kg/m^3]: of a material and a ball
  double density = 2400.0;              // rho [kg/m^3], in [kMinDensity, kMaxDensity]
  double tensile_strength = 3.0e6;      // sigma_b in tension [Pa], > 0
  double compressive_strength = 30e6;   // [Pa], >= tensile; equal to tensile -> von Mises criterion
  double fracture_strain = 1.5e-4;      // eps_b of the displacement criterion, > 0
  double friction = 0.6;                // Coulomb mu of contacts, >= 0
  double restitution = 0.2;             // coefficient of restitution of contacts, in [0.01, 1]
  // Rolling and twisting resistance of contacts (mu_r, mu_t: the torque caps are mu R F_n). A loose
  // automaton is a cube that contacts see as a sphere; 0.3 makes debris stop rolling within a few
  // times its size instead of rolling on for ever. In [0, 1].
  double rolling_friction = 0.3;
  double twisting_friction = 0.3;
  // Viscosity of the material as a relaxation time tau [s] (Kelvin-Voigt: a link's dashpot is tau times
  // its stiffness). A vibration of angular frequency omega is damped with ratio tau omega / 2: 5e-6 s
  // damps the lattice-scale ringing of an impact (without it a concrete block dropped flat from 5 cm
  // cracked) and gives the vibrations of a 1 m body about 3 % of critical. In [0, 1e-3].
  double damping_time = 5e-6;
  StrengtheningLaw strengthening = StrengtheningLaw::none;
  double strengthening_alpha = 0.0;     // alpha of eq. 7 (>= 0)
  // Fracture energy G_f [J/m^2]: a link whose equivalent stress reaches its strength softens (its
  // tensile and shear forces fall linearly with further load) and breaks when it has dissipated G_f
  // times its cross-section, so a crack costs G_f per unit area at every spacing (physics/fracture.hpp,
  // link_softening). 0: the paper's instant break. In [0, 1e6].
  double fracture_energy = 0.0;
  // Weibull modulus m of the links' strengths: each lattice link's strengths (and breaking strain) are
  // the weaker end's times its own factor, drawn from a Weibull distribution of modulus m and mean 1
  // (about 1.2 / m coefficient of variation). 0: no spread (every link the weaker end's). 0 or in [1, 100].
  double weibull_modulus = 0.0;
};

// Built-in materials: concrete, glass, ceramic, granite, steel.
const std::vector<MaterialDef>& builtin_materials();
// The built-in material of that name, or nullptr.
const MaterialDef* find_builtin_material(const std::string& name);

struct HeterogeneityDef {
  // Share P(c) of automata in strength class c = 1..4 (index 0..3); must sum to 1 within 1e-6.
  std::array<double, 4> shares = {0.0, 0.0, 0.0, 1.0};
  std::string preset = "none";  // none | low | medium | high | custom (informative once resolved)
  // Strength factor k_c of class c (default c/4): strengths and fracture strain are scaled by it.
  std::array<double, 4> class_factors = {0.25, 0.5, 0.75, 1.0};
  // 0: classes drawn independently per automaton (the paper). > 0: Voronoi grains of about this
  // size [m], each grain one class.
  double grain_size = 0.0;
};
// Shares of the paper's presets (section 5.1): low 0/0/10/90 %, medium 0/15/20/65 %, high 20/25/25/30 %,
// none 0/0/0/100 %. Returns false for an unknown name.
bool heterogeneity_preset(const std::string& name, std::array<double, 4>& shares);

enum class Shape { box, sphere, cylinder, mesh };

// Assigns a material group to the automata of an object whose centres lie inside the region.
// Coordinates are in the scene (world) frame. Later regions win over earlier ones.
struct RegionDef {
  Shape shape = Shape::box;       // box, sphere or mesh
  Vec3d center = {0, 0, 0};
  Vec3d size = {1, 1, 1};         // box: full extents along world axes
  double radius = 0.5;            // sphere
  // mesh (only in an object of shape mesh): a closed mesh in the units and frame of the object's mesh
  // file, placed by the object's scale, position and rotation; the automata inside it get the material.
  std::string mesh;
  std::string material;
};

// How a mesh object is filled with automata.
enum class MeshFill { volume, surface };

struct ObjectDef {
  std::string name = "object";
  Shape shape = Shape::box;
  Vec3d size = {1, 1, 1};          // box: full extents (object frame)
  double radius = 0.5;             // sphere, cylinder
  double height = 1.0;             // cylinder, along the object's local z axis
  // mesh: a triangle mesh file (OBJ, PLY, STL, OFF, glTF/GLB). The reader resolves it against the scene
  // file's folder, MCA_MESH_PATH and the models cache (io::find_mesh_file); here it is the path to open.
  std::string mesh;
  double scale = 1.0;              // mesh: factor from the file's units to metres, > 0
  double fit_size = 0.0;           // mesh: > 0 scales the mesh so its largest extent is this [m] (not with scale)
  // mesh: volume = the lattice cells whose centres are inside the mesh; surface = one automaton per
  // triangle, linked across shared edges (the paper's counts).
  MeshFill fill = MeshFill::volume;
  double shell_thickness = 0.0;    // mesh, surface fill: the shell's thickness [m]; 0 = the mean link length
  Vec3d position = {0, 0, 0};      // centre (mesh: where the centre of its bounding box goes)
  Vec3d rotation = {0, 0, 0};      // degrees about x, then y, then z (applied in that order)
  Vec3d velocity = {0, 0, 0};      // initial velocity [m/s]
  std::string material = "concrete";
  std::vector<RegionDef> regions;
  std::optional<HeterogeneityDef> heterogeneity;  // overrides the scene's
};

// A rigid sphere. Dynamic by default (momentum exchange with the automata); kinematic keeps its velocity.
struct ProjectileDef {
  std::string name = "ball";
  double radius = 0.1;             // [m]
  std::string material = "steel";  // stiffness, friction, restitution; density unless given below
  double density = 0.0;            // [kg/m^3]; 0 = the material's, else in MaterialDef's bounds
  Vec3d position = {0, 0, 0};
  Vec3d velocity = {0, 0, 0};
  Vec3d angular_velocity = {0, 0, 0};  // [rad/s]
  bool kinematic = false;
  // Rolling and twisting resistance of all its contacts, in [0, 1]: a ball is a sphere, so the small value
  // of a hard ball on a hard floor (the materials' 0.3 is that of cube-shaped automata).
  double rolling_friction = 0.01;
  double twisting_friction = 0.01;
};

// A boundary condition: the automata whose initial centres lie in the box move at a fixed velocity
// (zero holds them). The force the grip exerts is reported in stats.csv.
struct GripDef {
  std::string name = "grip";  // unique among the grips, no ',' '"' or control characters: names stats.csv columns
  Vec3d min = {0, 0, 0};
  Vec3d max = {0, 0, 0};
  Vec3d velocity = {0, 0, 0};
};

// A constant force on each automaton whose initial centre lies in the box (e.g. a surface traction
// times the face area d^2 of one automaton). Several loads on one automaton add up.
struct LoadDef {
  std::string name = "load";
  Vec3d min = {0, 0, 0};
  Vec3d max = {0, 0, 0};
  Vec3d force = {0, 0, 0};  // [N] per automaton
};

struct GroundDef {
  bool enabled = false;
  double height = 0.0;       // along the up axis (the axis gravity points down)
  double friction = 0.6;
  double restitution = 0.3;       // in [0.01, 1]
  double rolling_friction = 0.3;  // rolling and twisting resistance (see MaterialDef)
  double twisting_friction = 0.3;
};

struct SolverDef {
  // The spacings a scene may give (solver.spacing), in metres.
  static constexpr double kMinSpacing = 1e-9, kMaxSpacing = 1e9;
  // The most automata a model of lattice fills holds (links are addressed with 29 bits in the backends'
  // adjacency, 3 links an automaton), and so the largest target_automata.
  static constexpr std::int64_t kMaxAutomata = (std::int64_t{1} << 29) / 3;
  double spacing = 0.05;                 // lattice spacing d [m], in [kMinSpacing, kMaxSpacing]
  std::int64_t target_automata = 0;      // > 0: choose d so the count lands within 2 %
  double safety = 0.5;                   // C: the step is C x the critical step (time_step.cpp), in (0, 1]
  double time_step = 0.0;                // 0: automatic; else used as given (must be <= the stable one)
  // Selective mass scaling of surface-mode objects: an automaton whose own critical step is below this
  // share of its object's median gets mass (and moment of inertia) until it reaches it; 0: none. In [0, 1].
  double mass_scaling = 0.7;
  Vec3d gravity = {0, 0, -9.81};         // [m/s^2]; the up axis is the one opposite gravity (z if zero)
  double link_damping = 0.0;             // viscous damping of links, share of critical, in [0, 1]
  double local_damping = 0.0;            // Cundall local damping alpha, in [0, 0.2]
  double stress_coefficient = 1.0;       // K_v of the equivalent-stress criterion, > 0
  // Disorder of the lattice: each automaton of a lattice fill sits at its cell's centre moved by up to
  // this share of d along each of the lattice's axes (uniform, drawn from seed, object and cell); the
  // links keep the cubic connectivity and take their rest lengths and directions from the moved sites.
  // 0: the paper's cubic lattice. In [0, 0.3].
  double lattice_jitter = 0.0;
  // The lattice of the volume fills: random (the default: a site at a random point of each cell, linked
  // to its Voronoi neighbours, each link's cross-section their shared Voronoi face:
  // lattice/random_lattice.hpp; cracks follow the material, not lattice planes) or cubic (the paper's: a
  // site at each cell's centre, six face links; about 5 times faster per automaton-step, its cracks run
  // along its planes). Surface mode is unchanged.
  enum class Lattice { cubic, random } lattice = Lattice::random;
  // The random lattice's links' bending and twisting springs, as a share beta of a beam of the link's own
  // section (docs/model-notes.md, "The random lattice", Bending): without them (0) a line of intact links
  // is a hinge, and a cracked body swung on it as one piece. The default, 0.1, is the calibrated one (E,
  // nu and the tensile strength of a block); larger values stiffen the lattice and weaken it in tension
  // (at 1: E +1.5 %, nu -2.2 %, a pulled block 27 % weaker). 0 (the lattice of before them, its own
  // strength factor), or in [0.01, 1]; the cubic lattice has none.
  double link_bending = 0.1;
  // Where the step runs: auto (the GPU where there is one this build can use, else the CPU; MCA_BACKEND
  // says otherwise), cpu, cuda (an NVIDIA GPU; an error without one), or cuda-emulation (the CUDA
  // backend's algorithm run on one CPU core, thread by thread, for checking the GPU path without a GPU;
  // slower). The three give the same state bit for bit (tested; on a GPU by scripts/gpu_check.sh), and a
  // run saved on one resumes on another. Not part of the scene a checkpoint must match.
  enum class Backend { automatic, cpu, cuda, cuda_emulation } backend = Backend::automatic;
  double skin = 0.3;                     // contact search skin, share of d, in (0, 0.4]
  std::uint64_t seed = 1;
  double max_memory_gb = 16.0;           // refuse models whose estimate exceeds this
};

// A backend's name in scene files and options (auto, cpu, cuda, cuda-emulation), and back (none: no such name).
const char* backend_name(SolverDef::Backend backend);
std::optional<SolverDef::Backend> parse_backend(const std::string& name);

struct OutputDef {
  double duration = 0.05;       // simulated time [s]
  double frame_rate = 500.0;    // output frames per simulated second
  bool links = false;           // also write intact links as VTK lines
  bool vtk = true;              // write per-frame VTK files
  int checkpoint_every = 0;     // frames between checkpoints; 0 = none
  // Per frame, the bound surface of the mesh objects (Model::surface) as surface/surface_NNNNNN.ply (or
  // .obj), split into fragments; needs an object of shape mesh.
  bool surface = false;
  enum class SurfaceFormat { ply, obj } surface_format = SurfaceFormat::ply;
  // At the end of a run, a closed mesh per fragment of more than fragment_min_automata automata, as
  // fragments/fragment_NNN.ply (analysis/fragment_meshes.hpp).
  bool fragments = false;
  std::int64_t fragment_min_automata = 8;  // >= 0 (0: every fragment)
};

// The renderer's camera (mca run --render, mca view). Every key is optional: the target defaults to the
// centre of the objects' box at frame 0, the position to a 3/4 view that frames the whole box
// (render/camera.hpp).
struct CameraDef {
  std::optional<Vec3d> position;  // [m], world frame
  std::optional<Vec3d> target;    // [m], the point looked at
  double fov = 40.0;              // vertical field of view [degrees], in [5, 150]
};

struct SceneDef {
  std::string name = "scene";
  std::string source = "<built-in>";     // file the scene came from, for messages
  std::vector<MaterialDef> materials;    // user materials; built-ins are always available
  HeterogeneityDef heterogeneity;
  std::vector<ObjectDef> objects;
  std::vector<ProjectileDef> projectiles;
  std::vector<GripDef> grips;
  std::vector<LoadDef> loads;
  GroundDef ground;
  SolverDef solver;
  OutputDef output;
  CameraDef camera;
};

// Checks ranges and references; throws mca::Error naming the scene file, the key, the value and the fix.
void validate_scene(const SceneDef& scene);
// The material of that name: a user material first, then a built-in. Throws mca::Error if unknown.
const MaterialDef& resolve_material(const SceneDef& scene, const std::string& name, const std::string& key);

}  // namespace mca
