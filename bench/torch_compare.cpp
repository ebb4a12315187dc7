#include "torch_compare.hpp"

#include <algorithm>
#include <chrono>
#include <iomanip>
#include <ostream>

#include "bench.hpp"
#include "mlp_network.hpp"
#include "nova/train/optim.hpp"
#include "torch_peer.hpp"

namespace nova::bench {

void compare_with_torch(Runtime& rt, const MlpConfig& c, const std::vector<long>& batches,
                        int repeats, const std::string& python, int threads,
                        const std::string& device, std::ostream& out, std::ostream& csv) {
  csv << "batch,pass,nova_samples_per_s,torch_samples_per_s,nova_over_torch,torch\n";
  if (python.empty()) {
    out << "PyTorch: not compared (--torch off, or no /usr/bin/python3)\n";
    return;
  }
  bool headed = false;
  for (long batch_l : batches) {
    const size_t m = static_cast<size_t>(batch_l);
    for (bool train : {false, true}) {
      std::string why;
      TorchMlpShape shape{m, kMlpInputs, c.width, c.depth, c.skip, threads, device, !train};
      std::unique_ptr<TorchPeer> peer = TorchPeer::start(python, shape, why);
      if (!peer) {
        out << "PyTorch: not compared (" << why << ")\n";
        csv << "# PyTorch not compared: " << why << "\n";
        return;
      }
      if (!headed)
        out << "beside PyTorch (the same network; a training step is forward, backward and one Adam "
               "update in both; alternating step by step, medians of " << repeats << "):\n";
      headed = true;
      const auto net = mlp_network(rt, c, m, train);
      Executor& ex = *net->ex;
      Adam adam(rt, ex.parameter_floats());
      const auto nova_step = [&] {
        const auto t0 = std::chrono::steady_clock::now();
        ex.forward();
        if (train) {
          ex.backward();
          adam.step(ex.parameter_arena(), ex.gradient_arena(), 5e-4f);
        }
        rt.finish();
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      };
      nova_step();  // warm-up (kernel builds); the script warmed up before its greeting
      std::vector<double> nova_s, torch_s;
      for (int r = 0; r < std::max(repeats, 1); ++r) {
        nova_s.push_back(nova_step());
        torch_s.push_back(peer->step());
      }
      const double n = m / median(nova_s), t = m / median(torch_s);
      const char* pass = train ? "training step" : "forward";
      out << "  " << std::left << std::setw(8) << m << std::setw(15) << pass << std::right << std::fixed
          << std::setprecision(0) << " nova " << std::setw(8) << n << " samples/s   PyTorch "
          << std::setw(8) << t << " samples/s   nova / PyTorch " << std::setprecision(2) << n / t
          << "   [" << peer->version() << "]" << std::endl;
      csv << m << "," << pass << "," << n << "," << t << "," << n / t << "," << peer->version() << "\n";
    }
  }
}

}  // namespace nova::bench
