// Stopping a solve on request (core/cancel.h through hr/budget.h): a
// requested token stops the solve with hrad::Cancelled, from the start or
// from another thread mid-solve; a token never requested changes nothing.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "core/timer.h"
#include "hr/solver.h"
#include "scene/builtin.h"

using namespace hrad;
using namespace hrad::hr;

namespace {

HrSettings settings(double eps, const std::string& cluster = "auto") {
    Params p;
    p.set("hr.oracle", std::string("error"));
    p.set("oracle.eps", eps);
    p.set("cluster.model", cluster);
    HrSettings s = HrSettings::fromParams(p);
    p.reportUnused();
    return s;
}

}  // namespace

TEST(Cancel, RequestedTokenStopsTheSolve) {
    scene::Scene s = scene::makeBuiltin("cornell");
    transport::Visibility vis(s);
    HrSolver solver(s, vis, settings(3e-3));
    CancelToken token;
    token.request();
    solver.setCancelToken(&token);
    EXPECT_THROW(solver.solve(), Cancelled);
}

TEST(Cancel, TokenNeverRequestedChangesNothing) {
    scene::Scene s = scene::makeBuiltin("cornell");
    transport::Visibility vis(s);
    HrResult plain = HrSolver(s, vis, settings(3e-3)).solve();
    HrSolver solver(s, vis, settings(3e-3));
    CancelToken token;
    solver.setCancelToken(&token);
    HrResult withToken = solver.solve();
    EXPECT_EQ(withToken.history.size(), plain.history.size());
    EXPECT_EQ(withToken.field->totalPower(), plain.field->totalPower());
}

TEST(Cancel, RequestFromAnotherThreadStopsMidSolve) {
    // office:2 at eps = 1e-5 takes minutes (with clusters, linking is quick:
    // the initial linking polls no token); the request comes after 0.3 s and
    // the solve must be gone soon after (hr.max_seconds bounds a failure).
    scene::Scene s = scene::makeBuiltin("office:2");
    transport::Visibility vis(s);
    HrSettings st = settings(1e-5, "oriented");
    st.maxSeconds = 30;
    HrSolver solver(s, vis, st);
    CancelToken token;
    solver.setCancelToken(&token);
    std::thread stopper([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(300));
        token.request();
    });
    Timer t;
    EXPECT_THROW(solver.solve(), Cancelled);
    stopper.join();
    EXPECT_LT(t.seconds(), 2.0);
}
