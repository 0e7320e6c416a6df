// reefgen studio: the local web page (studio/, docs/STUDIO.md). Thin: resolve
// the model and the page's folder, start the server, stop it on Ctrl-C.
#include <torch/torch.h>

#include <atomic>
#include <optional>
#include <cstdio>
#include <cstdlib>
#include <thread>

#include "app.hpp"
#include "reefgen/install.hpp"
#include "reefgen/files.hpp"
#include "reefgen/interrupt.hpp"
#include "reefgen/model/shipped.hpp"
#include "reefgen/model/torch_threads.hpp"
#include "reefgen/studio/server.hpp"

namespace reefgen {

Command add_studio_command(CLI::App& app, const GlobalOptions& g) {
  auto* sub = app.add_subcommand(
      "studio",
      "Paint or shape an island in the browser and see it in 3D, live\n\n"
      "Examples:\n"
      "  reefgen studio                          # http://127.0.0.1:8080/ with the shipped model\n"
      "  reefgen studio --port 9000 --out my-islands\n"
      "  reefgen studio -m runs/try/generator.pt --precision bf16\n");
  struct Args {
    studio::StudioOptions o;
    std::string model, out = "studio-out", assets;
    std::optional<int> threads;
  };
  auto a = std::make_shared<Args>();
  sub->add_option("--host", a->o.host, "Address to listen on (loopback only by default)")->capture_default_str();
  sub->add_option("--port", a->o.port, "Port (0: any free one)")->capture_default_str()->check(CLI::Range(0, 65535));
  sub->add_option("-m,--model", a->model, "Generator file; default: the shipped model (models/reef-256.pt)");
  sub->add_option("-o,--out,--output", a->out, "The only folder the studio writes exports to")->capture_default_str();
  sub->add_option("--precision", a->o.precision, "fp32, bf16 or auto (as infer)")->capture_default_str();
  sub->add_option("--max-side", a->o.max_side, "Largest sketch / island side accepted, pixels")
      ->capture_default_str()
      ->check(CLI::Range(64, 4096));
  sub->add_option("--assets", a->assets, "The page's folder (default: the build's studio/assets)");
  sub->add_option("--threads", a->threads, "LibTorch threads (default: all cores)")->check(CLI::Range(1, 256));
  return {sub, [a, &g]() -> int {
            model::use_torch_threads(a->threads.value_or(default_threads()));
            a->o.model = model::resolve_model_path(a->model);
            a->o.out_dir = a->out;
            const char* env = std::getenv("REEFGEN_STUDIO_ASSETS");
            const fs::path installed = installed_data("studio");
            a->o.assets_dir = !a->assets.empty() ? fs::path(a->assets)
                              : env              ? fs::path(env)
                              : !installed.empty() ? installed
                                                   : fs::path(REEFGEN_STUDIO_ASSETS);
            if (!fs::exists(a->o.assets_dir / "index.html"))
              throw Error("studio: no page in " + a->o.assets_dir.string() + " (build it: bash scripts/build.sh)");
            a->o.presets = builtin_presets();
            studio::StudioServer server(a->o);
            const int port = server.bind();
            const std::string url = "http://" + a->o.host + ":" + std::to_string(port) + "/";
            install_stop_handlers();
            // A request being computed when Ctrl-C comes stops between its
            // steps (reefgen/interrupt.hpp) and is answered 503, so the studio
            // stops in a second or two, not when an 8192² answer is done.
            set_interrupt_hook(+[] {
              if (stop_requested()) throw Interrupted();
            });
            std::thread watcher([&] {
              while (!stop_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
              server.stop();
            });
            if (!g.quiet) std::fprintf(stderr, "reefgen studio: %s (Ctrl-C to stop; exports go to %s)\n", url.c_str(),
                                       fs::absolute(a->o.out_dir).c_str());
            std::printf("%s\n", url.c_str());
            std::fflush(stdout);
            server.serve();
            stop_requested() = true;
            watcher.join();
            if (!g.quiet) std::fprintf(stderr, "reefgen studio: stopped\n");
            return 0;
          }};
}

}  // namespace reefgen
