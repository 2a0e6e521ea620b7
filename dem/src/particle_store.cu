// ParticleStore: upload, reorder by a permutation, download.
#include "particle_store.hpp"

#include <algorithm>
#include <vector>

#include "core/error.hpp"
#include "format.hpp"
#include "state.hpp"

namespace lbdem::dem {

// Reorders every per-particle array: dst[i] = src[perm[i]].
struct Gather {
  const int* perm;
  const Real4 *pos, *vel, *omg, *frc, *trq, *frco, *trqo, *vpr, *wpr, *extf, *extt;
  Real4 *pos2, *vel2, *omg2, *frc2, *trq2, *frco2, *trqo2, *vpr2, *wpr2, *extf2, *extt2;
  const std::int64_t* gid;
  std::int64_t* gid2;
  const int* type;
  int* type2;
  const Vec3d* whist;
  Vec3d* whist2;
  int nwalls;
  Index n;
  LBDEM_HD void operator()(Index i) const {
    const Index o = perm[i];
    pos2[i] = pos[o]; vel2[i] = vel[o]; omg2[i] = omg[o]; frc2[i] = frc[o]; trq2[i] = trq[o];
    frco2[i] = frco[o]; trqo2[i] = trqo[o]; vpr2[i] = vpr[o];
    if (wpr) wpr2[i] = wpr[o];
    if (extf) { extf2[i] = extf[o]; extt2[i] = extt[o]; }
    gid2[i] = gid[o];
    type2[i] = type[o];
    if (whist)
      for (int w = 0; w < nwalls; ++w) whist2[w * n + i] = whist[w * n + o];
  }
};

namespace {

Real4 r4(const Vec3d& v, double w) { return Real4{v.x, v.y, v.z, w}; }

template <class T>
void upload_vector(Buffer<T>& b, Backend be, const std::vector<T>& v, Index n) {
  b = Buffer<T>(be, n);
  if (n > 0) b.copy_from_host(v.data(), n);
}

}  // namespace

void ParticleStore::upload(Backend be, const HostParticles& hp, const Box& box, const StoreLayout& lay) {
  layout = lay;
  n = n_owned = hp.size();
  std::vector<Real4> p(n), v(n), w(n), zero(n, Real4{0, 0, 0, 0});
  for (Index i = 0; i < n; ++i) {
    Vec3d x = box.wrap(hp.x[i]);
    p[i] = r4(x, hp.r[i]);
    if (!(hp.mass[i] > 0)) throw ConfigError(fmtx(("particles: mass {} of particle {} must be > 0"), hp.mass[i], i));
    v[i] = r4(hp.v[i], 1.0 / hp.mass[i]);
    w[i] = r4(hp.w.empty() ? Vec3d{} : hp.w[i], 1.0 / sphere_inertia(hp.mass[i], hp.r[i]));
  }
  {
    std::vector<std::int64_t> ids(hp.id.begin(), hp.id.end());
    std::sort(ids.begin(), ids.end());
    if (static_cast<Index>(ids.size()) != n || std::adjacent_find(ids.begin(), ids.end()) != ids.end())
      throw ConfigError("particles: global ids are missing or not unique");
  }
  upload_vector(pos, be, p, n);
  upload_vector(vel, be, v, n);
  upload_vector(omg, be, w, n);
  upload_vector(frc, be, zero, n);
  upload_vector(trq, be, zero, n);
  upload_vector(x0, be, p, n);
  upload_vector(gid, be, hp.id, n);
  std::vector<int> types = hp.type;
  types.resize(n, 0);
  upload_vector(type, be, types, n);
  pos2 = Buffer<Real4>(be, n);
  vel2 = Buffer<Real4>(be, n);
  omg2 = Buffer<Real4>(be, n);
  frc2 = Buffer<Real4>(be, n);
  trq2 = Buffer<Real4>(be, n);
  upload_vector(frco, be, zero, n);
  upload_vector(trqo, be, zero, n);
  upload_vector(vpr, be, v, n);
  vpr2 = Buffer<Real4>(be, n);
  if (layout.rotation) {
    upload_vector(wpr, be, w, n);
    wpr2 = Buffer<Real4>(be, n);
  }
  frco2 = Buffer<Real4>(be, n);
  trqo2 = Buffer<Real4>(be, n);
  gid2 = Buffer<std::int64_t>(be, n);
  type2 = Buffer<int>(be, n);
  if (layout.external_forcing) {
    upload_vector(extf, be, zero, n);
    upload_vector(extt, be, zero, n);
    extf2 = Buffer<Real4>(be, n);
    extt2 = Buffer<Real4>(be, n);
  }
  if (layout.wall_histories > 0) {
    const Index nw = n * layout.wall_histories;
    whist = Buffer<Vec3d>(be, nw);
    whist.fill_zero();
    whist2 = Buffer<Vec3d>(be, nw);
  }
}

void ParticleStore::reorder(const Exec& ex, const int* perm) {
  Gather g{perm,         pos.data(),   vel.data(),   omg.data(),   frc.data(),   trq.data(),   frco.data(),
           trqo.data(),  vpr.data(),   wpr.data(),   extf.data(),  extt.data(),  pos2.data(),  vel2.data(),
           omg2.data(),  frc2.data(),  trq2.data(),  frco2.data(), trqo2.data(), vpr2.data(),  wpr2.data(),
           extf2.data(), extt2.data(), gid.data(),   gid2.data(),  type.data(),  type2.data(), whist.data(),
           whist2.data(), layout.wall_histories, n};
  launch(ex, n, g);
  pos.swap(pos2); vel.swap(vel2); omg.swap(omg2); frc.swap(frc2); trq.swap(trq2);
  frco.swap(frco2); trqo.swap(trqo2); vpr.swap(vpr2); wpr.swap(wpr2);
  extf.swap(extf2); extt.swap(extt2); gid.swap(gid2); type.swap(type2);
  whist.swap(whist2);
}

HostParticles ParticleStore::download() const {
  HostParticles h;
  std::vector<Real4> p = pos.to_vector(), v = vel.to_vector(), w = omg.to_vector(), f = frc.to_vector(),
                     t = trq.to_vector();
  h.id = gid.to_vector();
  h.type = type.to_vector();
  h.id.resize(n);
  h.type.resize(n);
  for (Index i = 0; i < n; ++i) {
    h.x.push_back(xyz(p[i]));
    h.r.push_back(p[i].w);
    h.v.push_back(xyz(v[i]));
    h.mass.push_back(1.0 / v[i].w);
    h.w.push_back(xyz(w[i]));
    h.f.push_back(xyz(f[i]));
    h.t.push_back(layout.rotation ? xyz(t[i]) : Vec3d{});
  }
  return h;
}

void ParticleStore::bind(State& s) const {
  s.pos = pos.data(); s.vel = vel.data(); s.omg = omg.data(); s.frc = frc.data(); s.trq = trq.data();
  s.frc_old = frco.data(); s.trq_old = trqo.data();
  s.vpr = vpr.data(); s.wpr = wpr.data();
  s.extf = extf.data(); s.extt = extt.data(); s.x0 = x0.data(); s.gid = gid.data();
  s.whist = whist.data();
  s.n = n;
}

ParticleView ParticleStore::view() {
  ParticleView v;
  v.pos_r = pos.data();
  v.vel_im = vel.data();
  v.omega_ii = omg.data();
  v.ext_force = extf.data();
  v.ext_torque = extt.data();
  v.force = frc.data();
  v.torque = trq.data();
  v.n = n_owned;
  return v;
}

}  // namespace lbdem::dem
