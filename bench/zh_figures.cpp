// prt_zh_figures: how well K zonal-harmonic lobes fit a transfer file's SH
// rows, and how fast (issue 28, docs/LDPRT.md). For each K in 1..4: the
// transfer-space error sqrt(sum |t - t~|^2 / sum |t|^2) over every stored
// row and channel, the same after the greedy start alone, and the fit's time
// per row on all cores.
//
// usage: prt_zh_figures TRANSFER.prt [MAX_LOBES [ROUNDS [START_ROUNDS]]]
#include <prt/error.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/zh.h>

#include <tbb/parallel_for.h>
#include <tbb/enumerable_thread_specific.h>

#include <chrono>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s TRANSFER.prt [MAX_LOBES]\n", argv[0]);
    return 2;
  }
  try {
    const prt::Transfer t = prt::read_transfer(argv[1]);
    const int max_lobes = argc > 2 ? std::atoi(argv[2]) : 4;
    const int n = t.bands, nc = n * n;
    const std::size_t rows = t.coeffs.size() / std::size_t(nc);  // every channel of every stored row
    std::printf("%s: %d bands, %zu rows of %d coefficients (%d channel%s)\n", argv[1], n, rows, nc, t.channels,
                t.channels == 1 ? "" : "s");
    std::printf("| lobes | error | error after the greedy start | rounds | us per row |\n|--:|--:|--:|--:|--:|\n");
    for (int K = 1; K <= max_lobes; ++K) {
      prt::zh::FitOptions o;
      o.lobes = K;
      if (argc > 3) o.rounds = std::atoi(argv[3]);
      if (argc > 4) o.start_rounds = std::atoi(argv[4]);
      std::vector<double> res(rows), start(rows), norm(rows), taken(rows);
      const auto t0 = std::chrono::steady_clock::now();
      tbb::parallel_for(std::size_t(0), rows, [&](std::size_t r) {
        std::vector<double> x(t.coeffs.begin() + std::ptrdiff_t(r * nc), t.coeffs.begin() + std::ptrdiff_t((r + 1) * nc));
        const prt::zh::Fit f = prt::zh::fit_lobes(n, x.data(), o);
        res[r] = f.residual;
        taken[r] = f.rounds;
        start[r] = f.start_residual;
        double s = 0;
        for (double v : x) s += v * v;
        norm[r] = s;
      });
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      double a = 0, b = 0, c = 0, d = 0;
      for (std::size_t r = 0; r < rows; ++r) a += res[r], b += start[r], c += norm[r], d += taken[r];
      std::printf("| %d | %.3f%% | %.3f%% | %.1f | %.1f |\n", K, 100 * std::sqrt(a / c), 100 * std::sqrt(b / c),
                  d / double(rows), 1e6 * secs / double(rows));
    }
  } catch (const prt::Error& e) {
    std::fprintf(stderr, "prt_zh_figures: %s\n", e.what());
    return 1;
  }
  return 0;
}
