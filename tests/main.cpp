#define BOOST_TEST_MODULE nova
#include <boost/test/unit_test.hpp>
