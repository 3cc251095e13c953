/* sim_fields.c: per-tet fields of a frame for the time series (DESIGN §7,
 * issue 25): the volume ratio J = det F, the elastic energy density
 * psi(F) = E_e / V_e (paper Eq. 7-8), and the largest and smallest
 * singular values of F (principal stretches; the smallest is negative in
 * an inverted tet) and the inverted flag (J <= 0), from one SVD per tet.
 * Computed on the owned tets into a Vec of
 * VK_SIM_TET_FIELDS entries per tet, in the mesh's tet order, so that the
 * frame writer gathers it like the node positions. */
#include "simimpl.h"
#include <vkmaterial.h>

PetscErrorCode VKSimCreateTetFieldVec(VKSim sim, PetscInt per, Vec *f)
{
  const VKLayout *L = VKMeshLayout(sim->mesh);

  PetscFunctionBegin;
  PetscCall(VecCreateMPI(sim->comm, per * (L->eEnd - L->eStart), per * VKMeshTetCount(sim->mesh), f));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimTetFields(VKSim sim, Vec x, Vec f)
{
  VKMesh             m = sim->mesh;
  const VKLayout    *L = VKMeshLayout(m);
  const PetscScalar *a;
  PetscScalar       *fa;
  Vec                loc;
  const PetscReal   *gamma, *coupling;
  VKStretchBand      band;

  PetscFunctionBegin;
  PetscCall(VKMaterialGetGammaArrayRead(sim->mat, &gamma));
  PetscCall(VKMaterialGetCouplingArrayRead(sim->mat, &coupling));
  PetscCall(VKMaterialGetStretchBand(sim->mat, &band));
  PetscCall(VKMeshGetLocalPositions(x, &loc, &a));
  PetscCall(VecGetArray(f, &fa));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    const PetscReal *G = VKMeshTetGradients(m) + 12 * (L->eStart + e);
    PetscReal        X[12], F[9], J;
    VKPsiState       st;
    VKLayoutGatherTet(L, e, a, X);
    VKTetDeformation(G, X, F);
    PetscCall(VKPsiProject(F, NULL, &band, &st));
    J                             = st.svd.s[0] * st.svd.s[1] * st.svd.s[2];
    fa[VK_SIM_TET_FIELDS * e + 0] = J;
    fa[VK_SIM_TET_FIELDS * e + 1] = gamma[2 * e] * st.psi_s + gamma[2 * e + 1] * st.psi_v;
    if (coupling && coupling[2 * e] > 0) {
      VKCouplingState cs;
      PetscCall(VKCouplingProject(F, coupling[2 * e + 1], 0, NULL, &cs));
      fa[VK_SIM_TET_FIELDS * e + 1] += coupling[2 * e] * cs.psi;
    }
    fa[VK_SIM_TET_FIELDS * e + 2] = st.svd.s[0];
    fa[VK_SIM_TET_FIELDS * e + 3] = st.svd.s[2];
    fa[VK_SIM_TET_FIELDS * e + 4] = J <= 0;
  }
  PetscCall(VecRestoreArray(f, &fa));
  PetscCall(VKMeshRestoreLocalPositions(x, &loc, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimTetMaterial(VKSim sim, Vec f)
{
  VKMesh          m = sim->mesh;
  const VKLayout *L = VKMeshLayout(m);
  PetscScalar    *fa;
  const PetscReal *gamma;

  PetscFunctionBegin;
  PetscCall(VKMaterialGetGammaArrayRead(sim->mat, &gamma));
  PetscCall(VecGetArray(f, &fa));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    fa[3 * e + 0] = gamma[2 * e];
    fa[3 * e + 1] = gamma[2 * e + 1];
    fa[3 * e + 2] = VKMeshTetDomains(m)[L->eStart + e];
  }
  PetscCall(VecRestoreArray(f, &fa));
  PetscFunctionReturn(0);
}
