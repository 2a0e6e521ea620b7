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

void ParticleStore::upload(const Exec& ex, const HostParticles& hp, const Box& box, const StoreLayout& lay) {
  const Backend be = ex.backend();
  layout = lay;
  n = n_owned = hp.size();
  std::vector<Real4> p(n), v(n), w(n), zero(n, Real4{0, 0, 0, 0});
  for (Index i = 0; i < n; ++i) {
    Vec3d x = box.wrap(hp.x[i]);
    p[i] = r4(x, hp.r[i]);
    if (!(hp.mass[i] > 0)) throw ConfigError(fmtx(("particles: mass {} of particle {} must be > 0"), hp.mass[i], i));
    v[i] = r4(hp.v[i], 1.0 / hp.mass[i]);
    w[i] = r4(hp.w.empty() ? Vec3d{} : hp.w[i], 1.0 / (lay.inertia_factor * hp.mass[i] * hp.r[i] * hp.r[i]));
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
  // The reorder targets are written whole by each reorder before they are
  // swapped in; zeroed here so that no copy of them ever reads unset bytes.
  pos2 = Buffer<Real4>(be, n);
  vel2 = Buffer<Real4>(be, n);
  omg2 = Buffer<Real4>(be, n);
  frc2 = Buffer<Real4>(be, n);
  trq2 = Buffer<Real4>(be, n);
  for (auto* b : {&pos2, &vel2, &omg2, &frc2, &trq2}) b->fill_zero(ex);
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
    whist.fill_zero(ex);
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

void HostState::resize(Index count, const StoreLayout& lay) {
  n = count;
  const auto c = static_cast<std::size_t>(count);
  for (auto* v : {&pos, &vel, &omg, &frc, &trq, &frco, &trqo, &vpr}) v->resize(c);
  wpr.resize(lay.rotation ? c : 0);
  extf.resize(lay.external_forcing ? c : 0);
  extt.resize(lay.external_forcing ? c : 0);
  gid.resize(c);
  type.resize(c);
  whist.resize(c * static_cast<std::size_t>(lay.wall_histories));
}

namespace {

// Grows b (and its reorder twin) to hold n records, with head room so that a
// run whose particle count per rank drifts does not reallocate at every build.
template <class T>
void grow(Buffer<T>& b, Buffer<T>* twin, Backend be, Index n) {
  const Index want = n + n / 4 + 16;
  if (b.size() < n || b.backend() != be) b = Buffer<T>(be, want);
  if (twin && (twin->size() < n || twin->backend() != be)) *twin = Buffer<T>(be, want);
}

template <class T>
void put(Buffer<T>& b, const std::vector<T>& v) {
  if (!v.empty()) b.copy_from_host(v.data(), static_cast<Index>(v.size()));
}

template <class T>
void get(const Buffer<T>& b, std::vector<T>& v, Index count) {
  v.resize(static_cast<std::size_t>(count));
  if (count > 0) b.copy_to_host(v.data(), count);
}

}  // namespace

void ParticleStore::load(Backend be, const HostState& h) {
  n = h.n;
  n_owned = h.n_owned;
  grow(pos, &pos2, be, n); grow(vel, &vel2, be, n); grow(omg, &omg2, be, n);
  grow(frc, &frc2, be, n); grow(trq, &trq2, be, n); grow(frco, &frco2, be, n);
  grow(trqo, &trqo2, be, n); grow(vpr, &vpr2, be, n); grow(x0, static_cast<Buffer<Real4>*>(nullptr), be, n);
  grow(gid, &gid2, be, n); grow(type, &type2, be, n);
  if (layout.rotation) grow(wpr, &wpr2, be, n);
  if (layout.external_forcing) { grow(extf, &extf2, be, n); grow(extt, &extt2, be, n); }
  if (layout.wall_histories > 0) grow(whist, &whist2, be, n * layout.wall_histories);
  put(pos, h.pos); put(vel, h.vel); put(omg, h.omg); put(frc, h.frc); put(trq, h.trq);
  put(frco, h.frco); put(trqo, h.trqo); put(vpr, h.vpr); put(x0, h.pos);
  put(gid, h.gid); put(type, h.type);
  if (layout.rotation) put(wpr, h.wpr);
  if (layout.external_forcing) { put(extf, h.extf); put(extt, h.extt); }
  if (layout.wall_histories > 0) put(whist, h.whist);
}

void ParticleStore::save(HostState& h) const {
  const Index m = n_owned;
  h.n = h.n_owned = m;
  get(pos, h.pos, m); get(vel, h.vel, m); get(omg, h.omg, m); get(frc, h.frc, m); get(trq, h.trq, m);
  get(frco, h.frco, m); get(trqo, h.trqo, m); get(vpr, h.vpr, m);
  get(gid, h.gid, m); get(type, h.type, m);
  if (layout.rotation) get(wpr, h.wpr, m);
  else h.wpr.clear();
  if (layout.external_forcing) { get(extf, h.extf, m); get(extt, h.extt, m); }
  else { h.extf.clear(); h.extt.clear(); }
  h.whist.clear();
  const int nw = layout.wall_histories;
  if (nw > 0 && m > 0) {
    // Rows of stride n on the store, of stride m on the host.
    std::vector<Vec3d> all;
    get(whist, all, n * nw);
    h.whist.resize(static_cast<std::size_t>(m) * nw);
    for (int w = 0; w < nw; ++w)
      std::copy(all.begin() + w * n, all.begin() + w * n + m, h.whist.begin() + w * m);
  }
}

HostParticles ParticleStore::download() const {
  HostParticles h;
  // The owned records only (buffers may have head room that nothing wrote).
  const auto m = static_cast<std::size_t>(n_owned);
  auto get = [&](const auto& b, auto& v) {
    v.resize(m);
    if (m > 0) b.copy_to_host(v.data(), n_owned);
  };
  std::vector<Real4> p, v, w, f, t;
  get(pos, p); get(vel, v); get(omg, w); get(frc, f);
  if (layout.rotation) get(trq, t);
  get(gid, h.id);
  get(type, h.type);
  for (Index i = 0; i < n_owned; ++i) {
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
