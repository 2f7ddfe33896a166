"""PROTOTYPE (issue 4, not a library feature yet): bouncing ball as a complementarity-constrained
discrete action with the collision time as an unknown, solved in horizon windows.

Usage:  python scripts/prototypes/bouncing_ball_fmow.py N E T L     e.g.  300 1.0 2.5 10
        SIG=1e-6,1e-8,0 (default) sets the relaxation values sigma of the homotopy.

Formulation (Fetecau-Marsden-Ortiz-West style, with complementarity choosing the colliding step):
every step k splits at a sub-node q~_k at time fraction alpha_k = 1/2 + beta_k; the step's action is
L_d(q_k, q~_k, alpha_k h) + L_d(q~_k, q_{k+1}, (1 - alpha_k) h) (midpoint).  At the sub-node an impulse
mu_k acts along the gap gradient, with
    0 <= phi(q~_k)  ⟂  mu_k >= 0,      |beta_k| <= C mu_k   (no impulse -> the split is the midpoint),
    mu_k (v~+ + e v~-) = 0             (Newton restitution on the discrete momenta at q~_k),
all products relaxed by sigma (Scholtes), bound_relax_factor 0.  The first sigma must be small on the
problem's own scale (gap x impulse ~ m g h^2 ~ 1e-3 here): with sigma = 0.1 the relaxed windows hold
the ball up with impulses in the air (q~ ~ 2 cm, mu ~ 0.1) and never recover.  Windows of L
steps start from the last node and its discrete momentum p_L^- = D2 L_d; each window's guess is free
flight, with the first ground crossing located analytically, the sub-node placed there and the
flight continued with the impact law (v+ = -e v-), for every crossing in the window.  Ipopt's
bound_push/bound_frac are 1e-8: the default push (1e-2) moves a sub-node guessed on the ground far
from a window start that is only millimetres above it, and the window became infeasible.

Measured (N = 300, T = 2.5 s, H = 1 m, L = 10):
* e = 1, SIG = 1e-6,1e-8,0: impacts at 0.45152, 1.35457, 2.25762 s (exact to 5 digits),
  mu = 8.8589 (exact 2 m v), node apexes 0.99995 / 0.99998; 824 iterations, 0.29 s.
* e = 0.7, SIG = 0 (no relaxation, the event-located guess suffices): all windows converge,
  397 iterations, 0.20 s; apexes 0.4900 0.2400 0.1176 0.0576 0.0282 0.01384 0.00676 = e^(2k) H.
  With SIG = 1e-6,1e-8,0 one late window fails; with sigma starting at 0.1, the fifth bounce fails.
* e = 0.3: the first four apexes match (0.0899 0.0080 0.00073 ...), then the Zeno accumulation
  (bounces shorter than a step) makes later windows fail: resting contact is not in the guess yet.
Next: resting contact (mu = m g h per step) and Zeno accumulation in the guess, fewer iterations
(whole-window warm starts instead of a fresh homotopy per window), then move the
formulation into trajectory.TrajectoryNLP on NLP.complementarity_elements.
"""
import casadi as ca, numpy as np, time, sys
H=1.0; g=9.81; m=1.0
import os; SIGMAS=[float(v) for v in os.environ.get("SIG","1e-6,1e-8,0").split(",")]
N=int(sys.argv[1]); e=float(sys.argv[2]); T=float(sys.argv[3]); L=int(sys.argv[4])
h=T/N; C=10.0
def build(L):
    q=ca.SX.sym('q',L+1); qt=ca.SX.sym('qt',L); mu=ca.SX.sym('mu',L); be=ca.SX.sym('be',L)
    sig=ca.SX.sym('sig'); p0=ca.SX.sym('p0')
    D1=lambda a,b,hh: -m*(b-a)/hh - m*g*hh/2
    D2=lambda a,b,hh:  m*(b-a)/hh - m*g*hh/2
    h1=(0.5+be)*h; h2=(0.5-be)*h
    G=[];lb=[];ub=[]
    def eq(x): G.append(x); lb.append(0); ub.append(0)
    def le(x,u): G.append(x); lb.append(-np.inf); ub.append(u)
    def ge(x,l): G.append(x); lb.append(l); ub.append(np.inf)
    eq((p0 + D1(q[0],qt[0],h1[0]))/h)
    for k in range(L):
        eq((D2(q[k],qt[k],h1[k]) + D1(qt[k],q[k+1],h2[k]) + mu[k])/h)
        if k>=1: eq((D2(qt[k-1],q[k],h2[k-1]) + D1(q[k],qt[k],h1[k]))/h)
        le(qt[k]*mu[k]-sig,0)
        ge(C*mu[k]-be[k],0); ge(C*mu[k]+be[k],0)
        vm=D2(q[k],qt[k],h1[k])/m; vp=-D1(qt[k],q[k+1],h2[k])/m
        r=mu[k]*(vp+e*vm)
        le(r-sig,0); ge(r+sig,0)
    x=ca.vertcat(q,qt,mu,be)
    S=ca.nlpsol('S','ipopt',{'x':x,'f':ca.sumsqr(be),'g':ca.vertcat(*G),'p':ca.vertcat(sig,p0)},
        {'print_time':False,'ipopt':{'print_level':0,'sb':'yes','bound_relax_factor':0,'tol':1e-10,'max_iter':200,'mumps_scaling':0,'mumps_permuting_scaling':0,'bound_push':1e-8,'bound_frac':1e-8}})
    pend=ca.Function('pend',[x],[D2(qt[L-1],q[L],h2[L-1])])  # p_L^- = D2 Ld at the window's last node
    return S, lb, ub, pend
S,lb,ub,pend=build(L)
q0=H; p0=0.0
Q=[H]; T0=time.perf_counter(); tot=0; imps=[]
for w in range(N//L):
    # free-flight guess (penetrates the ground)
    v0=p0/m
    # event-located guess: piecewise free flight; every ground crossing gets a sub-node with the
    # impact law v+ = -e v-; a step can hold one event, later ones in the same step are merged
    tn=np.arange(L+1)*h; tc=np.arange(L)*h+h/2
    qg=np.empty(L+1); qtg=np.empty(L); mug=np.zeros(L); beg=np.zeros(L)
    segs=[]; ts0=0.0; y0=q0; vv=v0
    while True:
        disc=vv**2+2*g*y0
        dt=(vv+np.sqrt(max(disc,0.0)))/g
        if y0<=1e-12 and vv<=0: dt=np.inf   # resting: no further flight
        te=ts0+dt
        segs.append((ts0,te,y0,vv))
        if te>=L*h or not np.isfinite(te): break
        k=min(int(te//h),L-1)
        vimp=vv-g*dt; vout=-e*vimp
        if mug[k]==0:
            a=min(max((te-k*h)/h,0.02),0.98); beg[k]=a-0.5; mug[k]=m*(vout-vimp)
        if vout < 1e-3*np.sqrt(2*g*max(H,1e-9)):   # Zeno onset: guess resting contact from here
            segs.append((te,np.inf,0.0,0.0)); break
        ts0,y0,vv=te,0.0,vout
    def ev(t):
        for a,b,y,v in segs:
            if t<=b: return max(y+v*(t-a)-0.5*g*(t-a)**2,0.0) if np.isfinite(b) or v!=0 else 0.0
        return 0.0
    qg=np.array([ev(t) for t in tn]); qtg=np.array([ev(t) for t in tc])
    for k in np.where(mug>0)[0]: qtg[k]=0.0
    x0=np.r_[qg,qtg,mug,beg]
    lbx=np.r_[q0, np.zeros(L), np.zeros(L), np.zeros(L), -0.49*np.ones(L)]
    ubx=np.r_[q0, np.inf*np.ones(L), np.inf*np.ones(L), np.inf*np.ones(L), 0.49*np.ones(L)]
    lx=0; lg=0
    for s in SIGMAS:
        sol=S(x0=x0,lbx=lbx,ubx=ubx,lbg=lb,ubg=ub,p=[s,p0],lam_x0=lx,lam_g0=lg); st=S.stats(); tot+=st['iter_count']
        x0=sol['x']; lx=sol['lam_x']; lg=sol['lam_g']
        if st['return_status']!='Solve_Succeeded':
            print('window',w,'sigma',s,st['return_status'],'q0=%.3e p0=%.4f'%(q0,p0),'guess events',np.where(mug>0)[0], beg[mug>0], mug[mug>0]); break
    X=np.array(x0).ravel(); qq=X[:L+1]; qt=X[L+1:2*L+1]; mu=X[2*L+1:3*L+1]; be=X[3*L+1:]
    for k in np.where(mu>1e-8)[0]: imps.append(((w*L+k+0.5+be[k])*h, qt[k], mu[k]))
    Q+=list(qq[1:]); q0=qq[-1]; p0=float(pend(X))
print('time %.2f s, iterations %d'%(time.perf_counter()-T0, tot))
Q=np.array(Q); t=np.arange(len(Q))*h
tf=np.sqrt(2*H/g)
print('impacts (t, q~, mu):', [(round(a,5), float('%.1e'%b), round(c,4)) for a,b,c in imps])
print('exact impact times e=1:', [round(tf+2*i*tf,5) for i in range(3)], ' exact mu=2 m v =', round(2*m*np.sqrt(2*g*H),4))
ti=[a for a,_,_ in imps]
seg=np.r_[0,ti,t[-1]]
print('apexes:', [round(Q[(t>a)&(t<b)].max(),6) for a,b in zip(seg[1:-1],seg[2:]) if ((t>a)&(t<b)).any()])
print('min q', Q.min())
