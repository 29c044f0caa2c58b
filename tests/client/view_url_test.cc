// The viewer page's address that `caustica view` prints: whatever the token holds, the page's
// URLSearchParams reads back the token and the scene id that were given.
#include <gtest/gtest.h>

#include "client/commands.h"

namespace caustica::client {
namespace {

TEST(ViewerUrl, TokenAndSceneAreReadBackWhole) {
  EXPECT_EQ(viewer_url("127.0.0.1", 8080, "s-1", ""), "http://127.0.0.1:8080/?scene=s-1");
  EXPECT_EQ(viewer_url("127.0.0.1", 8080, "s-1", "abc~_.-XYZ09"),
            "http://127.0.0.1:8080/?scene=s-1&token=abc~_.-XYZ09");
  // '&' and '#' would end the value, '+' would read as a space and '%' would start an escape.
  EXPECT_EQ(viewer_url("[::1]", 9, "s 1", "a&b=c+d%e#f/g"),
            "http://[::1]:9/?scene=s%201&token=a%26b%3Dc%2Bd%25e%23f%2Fg");
}

}  // namespace
}  // namespace caustica::client
