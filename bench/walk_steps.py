"""Work per subsurface random walk: Caustic's classic walk against Cycles' Dwivedi-guided one.

Usage (plain Python, no numpy):

    python3 bench/walk_steps.py [WALKS]

A half-space (entry at z = 0, medium below), one colour channel, isotropic phase, sigma_t = 1,
the albedo fit both renderers use (`medium::single_scattering_albedo`, Cycles'
`subsurface_random_walk_remap`) at the subsurface bench scene's three base-colour channels.
"classic" is Caustic's `medium::walk::random_walk` (free flights, isotropic directions, weight
alpha per scatter); "guided" is Cycles' `subsurface_random_walk` (intern/cycles/kernel/integrator/
subsurface_random_walk.h, read, not copied): after the first step, with probability 1/2 (3/4
after the similarity step 9) a direction from Dwivedi's phase about the entry normal and a
stretched free flight, every step weighted by the balance heuristic of the two (no opposite
interface in a half-space, so no backward guiding). Prints steps per walk and each walk's mean
weight (the diffuse reflectance, which both estimate: they must agree within their errors) and
its variance per walk.
"""

import math, random, sys

def fit_alpha(a, g=0.0):
    poly = lambda c: sum(k * g**i for i, k in enumerate(c))
    A=[1.8260523782,-1.28451056436,-1.79904629312,9.19393289202,-22.8215585862,32.0234874259,-23.6264803333,7.21067002658]
    B=[0.0,31.1491581433,-201.847017512,841.576016723,-2018.09288505,2731.71560286,-1935.41424244,559.009054474]
    C=[1.09686102424,-0.394704063468,1.05258115941,-8.83963712726,28.8643230661,-46.8802913581,38.5402837518,-12.7181042538]
    D=[0.496310210422,0.360146581622,-2.15139309747,17.8896899217,-55.2984010333,82.065982243,-58.5106008578,15.8478295021]
    E=[0.0,76.7316253952,-594.356773233,2448.8834203,-5576.68528998,7116.60171912,-4763.54467887,1303.5318055]
    F=[2.40602999408,-2.51814844609,9.18494908356,-79.2191708682,259.082868209,-403.613804597,302.85712436,-87.4370473567]
    b = 4.98511194385 + 0.127355959438 * math.exp(poly(B)); e = 4.23190299701 + 0.00310603949088 * math.exp(poly(E))
    bl = a ** 0.25
    return min(max((1-bl)*poly(A)*math.atan(b*a)**poly(C) + bl*poly(D)*math.atan(e*a)**poly(F), 0.0), 0.999999)

def iso(r1, r2):
    c = 1 - 2*r1; s = math.sqrt(max(0.0, 1-c*c)); p = 2*math.pi*r2
    return (s*math.cos(p), s*math.sin(p), c)

def walk(alpha, guided, rng):
    # cosine-weighted entry into -z
    r1, r2 = rng.random(), rng.random()
    s = math.sqrt(r1); p = 2*math.pi*r2
    d = (s*math.cos(p), s*math.sin(p), -math.sqrt(max(0.0, 1-r1)))
    z = 0.0; w = 1.0
    v = 1.0 / math.sqrt(1.0 - alpha ** (2.44294 - 0.0215813*alpha + 0.578637/alpha))
    plog = math.log((v+1)/(v-1))
    for bounce in range(256):
        gf = 0.5 if bounce <= 9 else 0.75
        stretch, fpf = 1.0, 0.0
        if bounce > 0:
            if guided and rng.random() < gf:
                ct = v - (v+1)*math.exp(-rng.random()*plog)
                sn = math.sqrt(max(0.0, 1-ct*ct)); ph = 2*math.pi*rng.random()
                d = (sn*math.cos(ph), sn*math.sin(ph), ct)
                stretch = 1 - ct / v
                samp = stretch
            else:
                d = iso(rng.random(), rng.random()); samp = 1.0
                ct = d[2]; stretch = 1 - ct / v
            fpf = (1/(2*math.pi)) * (1/((v-ct)*plog)) / (1/(4*math.pi))
        else:
            samp = 1.0
        t = -math.log(1 - rng.random()) / samp
        hit = d[2] > 0 and z + t*d[2] > 0
        if hit:
            t = -z / d[2]
        tr = math.exp(-t)
        pdf = tr if hit else tr
        if guided and bounce > 0:
            gp = math.exp(-stretch*t) * (1.0 if hit else stretch) * fpf
            pdf = (1-gf)*(tr) + gf*gp
        w *= (tr if hit else alpha*tr) / pdf
        z += t*d[2]
        if hit:
            return bounce + 1, w
        if w < 1e-6:
            return bounce + 1, 0.0
    return 256, 0.0

rng = random.Random(1)
n = int(sys.argv[1]) if len(sys.argv) > 1 else 20000
for colour in (0.8, 0.55, 0.45):
    a = fit_alpha(colour)
    for guided in (False, True):
        steps = 0; s = 0.0; s2 = 0.0
        for _ in range(n):
            k, w = walk(a, guided, rng); steps += k; s += w; s2 += w*w
        m = s/n; se = math.sqrt(max(0.0, s2/n - m*m)/n)
        print(f"colour {colour} alpha {a:.5f} {'guided' if guided else 'classic'}: steps/walk {steps/n:6.2f}  R = {m:.4f} +- {se:.4f}  var/walk {s2/n-m*m:.4f}")
