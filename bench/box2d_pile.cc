// box2d_pile.cc: the deposition scene of bench/README.md run by Box2D 2.4 (Debian libbox2d-dev),
// the speed reference for 2D rigid bodies: N polydisperse disks (radii 0.8-1.2 x 5 mm) on the loose
// lattice of moreau's pack generator (the same positions and radii, from the same counter-based
// generator), in a box with a floor and two walls, mu = 0.5, no restitution, h = 1 ms, 1 s.
// Box2D's default 8 velocity and 3 position iterations, sleeping off; lengths (and gravity) scaled
// by 100 so that its fixed 5 mm slop is 1 % of a radius.
//   box2d_pile N COLUMNS [STEPS] [VELOCITY_ITERATIONS]
// prints one line: box2d N=... steps=... time_per_step_ms=... (wall clock) cpu_per_step_ms=... (the
// thread's CPU time) contacts=... (touching contacts per step, averaged), us_per_contact=... (CPU)
#include <box2d/box2d.h>

#include <chrono>
#include <time.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>

// moreau's pack_uniform (src/body_rigid.c): SplitMix64's finalizer on (seed, grain, draw)
static double pack_uniform(unsigned long seed, int grain, int draw)
{
  unsigned long long z = (unsigned long long)seed * 0x9E3779B97F4A7C15ULL + (unsigned long long)grain * 0xBF58476D1CE4E5B9ULL +
                         (unsigned long long)draw * 0x94D049BB133111EBULL + 0x632BE59BD9B4E019ULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

int main(int argc, char **argv)
{
  if (argc < 3) {
    std::fprintf(stderr, "usage: box2d_pile N COLUMNS [STEPS] [VELOCITY_ITERATIONS]\n");
    return 2;
  }
  const int n = std::atoi(argv[1]), cols = std::atoi(argv[2]);
  const int steps = argc > 3 ? std::atoi(argv[3]) : 1000, vit = argc > 4 ? std::atoi(argv[4]) : 8;
  const double L = 100;                                    // length scale
  const double R = 0.005, disp = 0.2, s = 2.2 * R * (1 + disp), jit = 0.5, rho = 2600, h = 1e-3;
  const double W = cols * s;
  b2World world(b2Vec2(0.0f, (float)(-9.81 * L)));
  world.SetAllowSleeping(false);
  // the box: floor and walls as edges of a static body
  b2BodyDef bd;
  b2Body *box = world.CreateBody(&bd);
  b2EdgeShape e;
  b2FixtureDef fe;
  fe.shape = &e;
  fe.friction = 0.5f;
  const float H = (float)(L * (s * (n / cols + 2) + 1));
  e.SetTwoSided(b2Vec2(0, 0), b2Vec2((float)(L * W), 0));
  box->CreateFixture(&fe);
  e.SetTwoSided(b2Vec2(0, 0), b2Vec2(0, H));
  box->CreateFixture(&fe);
  e.SetTwoSided(b2Vec2((float)(L * W), 0), b2Vec2((float)(L * W), H));
  box->CreateFixture(&fe);
  for (int k = 0; k < n; k++) {
    double r = R * (1 + disp * (2 * pack_uniform(1, k, 0) - 1)), fr = 0.5 * s - r;
    double x = s * (k % cols + 0.5) + jit * fr * (2 * pack_uniform(1, k, 1) - 1);
    double y = s * (k / cols + 0.5) + jit * fr * (2 * pack_uniform(1, k, 2) - 1);
    b2BodyDef db;
    db.type = b2_dynamicBody;
    db.position.Set((float)(L * x), (float)(L * y));
    b2Body *b = world.CreateBody(&db);
    b2CircleShape c;
    c.m_radius = (float)(L * r);
    b2FixtureDef f;
    f.shape = &c;
    f.density = (float)rho;
    f.friction = 0.5f;
    f.restitution = 0.0f;
    b->CreateFixture(&f);
  }
  // the clock runs over world.Step alone; the touching contacts are counted between steps
  // (wall clock, and the thread's CPU time: on a shared machine the CPU time is the steadier)
  long touching = 0;
  double sec = 0, cpu = 0;
  for (int k = 0; k < steps; k++) {
    struct timespec c0, c1;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
    auto t0 = std::chrono::steady_clock::now();
    world.Step((float)h, vit, 3);
    sec += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
    cpu += (double)(c1.tv_sec - c0.tv_sec) + 1e-9 * (double)(c1.tv_nsec - c0.tv_nsec);
    for (b2Contact *c = world.GetContactList(); c; c = c->GetNext()) touching += c->IsTouching();
  }
  // the final state: the height of the pile (highest disk top) and its kinetic energy, scaled back
  double top = 0, ek = 0;
  for (b2Body *b = world.GetBodyList(); b; b = b->GetNext()) {
    if (b->GetType() != b2_dynamicBody) continue;
    double r = b->GetFixtureList()->GetShape()->m_radius / L, y = b->GetPosition().y / L;
    double v = b->GetLinearVelocity().Length() / L, m = rho * M_PI * r * r;
    if (y + r > top) top = y + r;
    ek += 0.5 * m * v * v;
  }
  std::printf("box2d N=%d steps=%d velocity_iterations=%d time_per_step_ms=%.4f cpu_per_step_ms=%.4f contacts=%.1f "
              "us_per_contact=%.3f pile_height=%.4f kinetic=%.3e\n",
              n, steps, vit, 1e3 * sec / steps, 1e3 * cpu / steps, (double)touching / steps,
              1e6 * cpu / (double)(touching ? touching : 1), top, ek);
  return 0;
}
