// softhom demo: runs the built-in material-point examples (the RVE → calibration → tube chain joins
// here as those engines land) and reports where the files are.
#include <iostream>

#include "commands.hpp"
#include "embedded_scenes.hpp"
#include "point_output.hpp"
#include "softhom/io/plot.hpp"
#include "softhom/io/scene.hpp"

namespace softhom::app {

int run_demo(const CommandOptions& options) {
  if (!options.scene.empty()) std::cerr << "softhom demo: ignoring the scene argument (the demo runs its built-in scenes)\n";
  struct Case {
    const char* scene;
    bool expect_completion;  // point_locking must stop at the Gent limit
  };
  const Case cases[] = {{"point_uniaxial_ecoflex", true}, {"point_uniaxial_fiber", true},
                        {"point_equibiaxial_fiber30", true}, {"point_relaxation", true},
                        {"point_locking", false}};
  int failures = 0;
  std::cout << "softhom demo: material-point examples (spec §5 closed forms, QLV relaxation, Gent locking)\n";
  for (const Case& c : cases) {
    LoadedScene scene;
    scene.name = c.scene;
    scene.table = io::parse_scene(embedded_scenes().at(c.scene), std::string("<embedded ") + c.scene + ".toml>");
    const auto dir = options.out / c.scene;
    const PointRun run = run_point_scene(scene, dir, options.quiet);
    const auto& last = run.result.steps.back();
    const bool as_expected = run.result.completed == c.expect_completion;
    if (!as_expected) ++failures;
    std::cout << "  " << c.scene << ": " << (run.result.completed ? "completed" : "stopped early (expected)")
              << ", t = " << last.t << ", F11 = " << last.F(0, 0) << ", sigma11 = " << last.sigma(0, 0)
              << " MPa, " << run.result.total_newton_iterations << " Newton iterations → "
              << (dir / "response.csv").string() << (as_expected ? "" : "   <-- UNEXPECTED") << "\n";
    if (!run.result.completed) std::cout << "      " << run.result.error << "\n";
    const bool in_time = std::string(c.scene) == "point_relaxation";
    io::PlotSpec plot{c.scene, in_time ? "t [s]" : "stretch F11", "Cauchy stress sigma11 [MPa]",
                      {{"sigma11", dir / "response.csv", in_time ? "t" : "F11", "sigma11"}}};
    std::string why;
    if (io::plot_curves(dir / "sigma11.png", plot, &why)) std::cout << "      plot: " << (dir / "sigma11.png").string() << "\n";
    else if (!options.quiet) std::cerr << "softhom demo: no PNG plot: " << why << "\n";
  }
  std::cout << "softhom demo: results under " << options.out.string() << "/<scene>/{response.csv,summary.json}\n";
  return failures == 0 ? 0 : 1;
}

}  // namespace softhom::app
