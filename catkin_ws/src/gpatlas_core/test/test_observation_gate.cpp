#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_core/model/multiscale_gpis_model.h"
#include "gpatlas_core/observations/observation_gate.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <gtest/gtest.h>

#include <limits>

using namespace gpatlas_core;
using gpatlas_core::testing::AnalyticSphere;

namespace {

// The upper half of a 10 cm sphere seen from above.
MultiscaleGpisModel fittedSphere(const AnalyticSphere& sphere) {
  MultiscaleGpisModel model;
  const FitReport fit = model.fit(sphere.view(800, 0.0, 0.1, 1));
  EXPECT_TRUE(fit.ok) << fit.message;
  return model;
}

Contact contactAt(const Vector3& position, const Vector3& normal = Vector3::Zero()) {
  Contact c;
  c.position = position;
  c.normal = normal;
  return c;
}

void expectSameModel(const SurfaceModel& a, const SurfaceModel& b, const AnalyticSphere& sphere) {
  EXPECT_EQ(a.observations().size(), b.observations().size());
  EXPECT_DOUBLE_EQ(a.scale(), b.scale());
  EXPECT_TRUE(a.centroid().isApprox(b.centroid()));
  for (const Vector3& x : {sphere.centre, Vector3(sphere.centre + Vector3(0.0, 0.0, -sphere.radius)),
                           Vector3(sphere.centre + Vector3(0.05, 0.02, 0.1))})
    EXPECT_DOUBLE_EQ(a.mean(x), b.mean(x));
}

TEST(ObservationGate, AFarOutlierContactIsRefusedAndTheModelIsUnchanged) {
  const AnalyticSphere sphere;
  MultiscaleGpisModel model = fittedSphere(sphere);
  const MultiscaleGpisModel before = model;
  TouchObservationConfig config;
  // 0.5 m beside the sphere: today's model would renormalise to it and move its frame.
  const TouchUpdate update =
      applyTouch(model, {contactAt(sphere.centre + Vector3(0.5, 0.0, 0.0), Vector3::UnitX())}, {}, config);
  EXPECT_FALSE(update.ok);
  EXPECT_EQ(update.contacts_refused.inconsistent, 1u);
  EXPECT_NE(update.message.find("inconsistent with the model"), std::string::npos) << update.message;
  EXPECT_NE(update.message.find("outside the model's domain"), std::string::npos) << update.message;
  expectSameModel(model, before, sphere);

  // With the gate off the same contact is taken, and it does move the frame: the test above is
  // the gate's doing.
  config.gate.max_contact_distance_m = std::nullopt;
  MultiscaleGpisModel ungated = before;
  const TouchUpdate taken =
      applyTouch(ungated, {contactAt(sphere.centre + Vector3(0.5, 0.0, 0.0), Vector3::UnitX())}, {}, config);
  EXPECT_TRUE(taken.ok) << taken.message;
  EXPECT_GT(ungated.scale(), 2.0 * before.scale());
}

TEST(ObservationGate, AContactTheModelCanExplainPassesEvenFarFromTheData) {
  const AnalyticSphere sphere;
  MultiscaleGpisModel model = fittedSphere(sphere);
  // The unseen underside, 1.5 cm below where the model puts it and 10 cm from every view point
  // (the view is the upper half): uncertain there, so consistent.
  const Vector3 underside = sphere.centre + Vector3(0.0, 0.0, -sphere.radius - 0.015);
  ASSERT_GT(model.nearestSurfaceDistance(underside), 0.1);
  TouchObservationConfig config;
  const TouchUpdate update = applyTouch(model, {contactAt(underside, -Vector3::UnitZ())}, {}, config);
  EXPECT_TRUE(update.ok) << update.message;
  EXPECT_EQ(update.contacts_refused.total(), 0u);
  EXPECT_EQ(update.contacts_added, 1);
}

TEST(ObservationGate, ConfidentFreeSpaceMakesADistantContactInconsistent) {
  // Where the model is sure there is no surface (|f| many sd from 0), a contact far from the
  // data is refused even inside the domain.
  const AnalyticSphere sphere;
  const MultiscaleGpisModel model = fittedSphere(sphere);
  const Vector3 inside_domain = sphere.centre + Vector3(0.0, 0.0, 0.25);
  ASSERT_TRUE(model.inDomain(inside_domain));
  const Prediction p = model.predict(inside_domain);
  const double sigmas = std::abs(p.mean) / std::sqrt(p.variance / model.varianceUnitFactor());
  ObservationGateConfig gate;
  gate.max_inconsistency_sigma = 0.5 * sigmas;
  EXPECT_EQ(gateObservations(model, {contactAt(inside_domain)}, {}, gate).contacts_refused.inconsistent, 1u);
  gate.max_inconsistency_sigma = 2.0 * sigmas;
  EXPECT_EQ(gateObservations(model, {contactAt(inside_domain)}, {}, gate).contacts.size(), 1u);
}

TEST(ObservationGate, NonFiniteAndOutOfWorkspaceObservationsAreCountedApart) {
  const AnalyticSphere sphere;
  MultiscaleGpisModel model = fittedSphere(sphere);
  ObservationGateConfig gate;
  gate.workspace_min_m = sphere.centre - Vector3::Constant(0.3);
  gate.workspace_max_m = sphere.centre + Vector3::Constant(0.3);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Vector3 top = sphere.centre + Vector3(0.0, 0.0, sphere.radius);
  const std::vector<Contact> contacts{contactAt(top, Vector3::UnitZ()), contactAt(Vector3(nan, 0.0, 0.0)),
                                      contactAt(Vector3(10.0, 0.0, 0.0)),
                                      contactAt(top + Vector3(0.01, 0.0, 0.0), Vector3(nan, nan, nan))};
  const std::vector<Vector3> free_space{top + Vector3(0.0, 0.0, 0.02), Vector3(0.0, nan, 0.0), Vector3(0.0, 0.0, 10.0)};
  const GatedObservations gated = gateObservations(model, contacts, free_space, gate);
  ASSERT_EQ(gated.contacts.size(), 2u);
  EXPECT_TRUE(gated.contacts[1].normal.isZero());  // a non-finite normal becomes unknown
  EXPECT_EQ(gated.contacts_refused.non_finite, 1u);
  EXPECT_EQ(gated.contacts_refused.outside_workspace, 1u);
  EXPECT_EQ(gated.free_space.size(), 1u);
  EXPECT_EQ(gated.free_space_refused.non_finite, 1u);
  EXPECT_EQ(gated.free_space_refused.outside_workspace, 1u);
  EXPECT_EQ(gated.message,
            "refused 2 contacts (1 not finite, 1 outside the workspace box) and 2 free-space points (1 not finite, 1 "
            "outside the workspace box)");

  // The same through applyTouch: the good ones are added and the answer counts the rest.
  TouchObservationConfig config;
  config.gate = gate;
  const TouchUpdate update = applyTouch(model, contacts, free_space, config);
  EXPECT_TRUE(update.ok) << update.message;
  EXPECT_EQ(update.contacts_added, 2);
  // Where the added contacts are: the two finite ones inside the workspace, not the refused.
  EXPECT_EQ(update.contact_positions, (std::vector<Vector3>{contacts[0].position, contacts[3].position}));
  EXPECT_EQ(update.contacts_refused.total() + update.free_space_refused.total(), 4u);
  ASSERT_FALSE(update.warnings.empty());
  EXPECT_EQ(update.warnings.front(), gated.message);
}

TEST(ObservationGate, InvalidConfigurationIsRefused) {
  ObservationGateConfig gate;
  EXPECT_EQ(validate(gate), "");
  gate.workspace_min_m = Vector3(1.0, 0.0, 0.0);
  gate.workspace_max_m = Vector3(0.0, 1.0, 1.0);
  EXPECT_NE(validate(gate).find("workspace_min_m"), std::string::npos);
  gate = ObservationGateConfig();
  gate.max_inconsistency_sigma = 0.0;
  EXPECT_NE(validate(gate).find("max_inconsistency_sigma"), std::string::npos);
  TouchObservationConfig touch;
  touch.gate.max_contact_distance_m = -1.0;
  EXPECT_NE(validate(touch).find("gate: max_contact_distance_m"), std::string::npos);
}

}  // namespace
