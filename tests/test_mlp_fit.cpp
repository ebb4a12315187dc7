// The reference network trains: 63 -> 8 x 256 (input re-fed after layer index 4) -> 4 fits a
// smooth 3D function and its held-out loss falls at least 100-fold.
#include <boost/test/unit_test.hpp>

#include "harness.hpp"
#include "nova/train/mlp_fit.hpp"

using namespace nova;

BOOST_AUTO_TEST_SUITE(mlp_fit)

BOOST_AUTO_TEST_CASE(reference_network_loss_falls_100_fold) {
  MlpFitConfig c;  // MlpConfig defaults are the reference: depth 8, width 256, skip 4
  c.batch = 512;
  c.steps = 150;
  c.lr = 1e-3f;
  const auto r = fit_smooth_function(test::runtime(), c);
  BOOST_TEST_MESSAGE("held-out loss " << r.initial_loss << " -> " << r.final_loss << " in "
                     << r.seconds << " s (" << r.samples_per_second << " samples/s)");
  BOOST_TEST(r.final_loss * 100 < r.initial_loss);
}

BOOST_AUTO_TEST_SUITE_END()
