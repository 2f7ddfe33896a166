"""PROTOTYPE (issue 4, not a library feature yet): bouncing ball as a complementarity-constrained
discrete action with the collision time as an unknown, solved in horizon windows.

Usage:  python scripts/prototypes/bouncing_ball_fmow.py N E T L     e.g.  300 1.0 2.5 10

Formulation (Fetecau-Marsden-Ortiz-West style, with complementarity choosing the colliding step):
every step k splits at a sub-node q~_k at time fraction alpha_k = 1/2 + beta_k; the step's action is
L_d(q_k, q~_k, alpha_k h) + L_d(q~_k, q_{k+1}, (1 - alpha_k) h) (midpoint).  At the sub-node an impulse
mu_k acts along the gap gradient, with
    0 <= phi(q~_k)  ⟂  mu_k >= 0,      |beta_k| <= C mu_k   (no impulse -> the split is the midpoint),
    mu_k (v~+ + e v~-) = 0             (Newton restitution on the discrete momenta at q~_k),
all products relaxed by sigma (Scholtes, sigma = 0.1 ... 0), bound_relax_factor 0.  Windows of L
steps start from the last node and its discrete momentum p_L^- = D2 L_d; each window's guess is free
flight, with the first ground crossing located analytically, the sub-node placed there and the
flight continued with the impact law (v+ = -e v-).

Measured (N = 300, T = 2.5 s, H = 1 m, L = 10):
* e = 1: impacts at 0.45152, 1.35457, 2.25762 s (exact to 5 digits), mu = 8.8589 (exact 2 m v),
  node apexes 0.99995 / 0.99998 (energy conserved; impact time not locked to the grid).
* e = 0.7: the first three impacts and apexes 0.490 / 0.2400 / 0.1176 match e^(2k) H; from the
  fourth bounce on the windows become infeasible (several impacts per window and the onset of
  Zeno/resting contact are not handled by the guess yet).
* e = 0.3: fails after the second bounce for the same reason.
Next: several events per window in the guess, resting contact (mu = m g h per node), then move the
formulation into trajectory.TrajectoryNLP on NLP.complementarity_elements.
"""
import casadi as ca, numpy as np, time, sys
H=1.0; g=9.81; m=1.0
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
        {'print_time':False,'ipopt':{'print_level':0,'sb':'yes','bound_relax_factor':0,'tol':1e-10,'max_iter':200,'mumps_scaling':0,'mumps_permuting_scaling':0}})
    pend=ca.Function('pend',[x],[D2(qt[L-1],q[L],h2[L-1])])  # p_L^- = D2 Ld at the window's last node
    return S, lb, ub, pend
S,lb,ub,pend=build(L)
q0=H; p0=0.0
Q=[H]; T0=time.perf_counter(); tot=0; imps=[]
for w in range(N//L):
    # free-flight guess (penetrates the ground)
    v0=p0/m
    # event-located guess: free flight; at the first ground crossing put the sub-node there,
    # apply the impact law (v+ = -e v-) and continue in free flight
    def flight(t, y0, vv): return y0+vv*t-0.5*g*t**2
    tn=np.arange(L+1)*h; tc=np.arange(L)*h
    disc=v0**2+2*g*q0
    ts=(v0+np.sqrt(disc))/g if disc>=0 else np.inf   # time of ground contact (root of flight = 0)
    qg=flight(tn,q0,v0); qtg=flight(tc+h/2,q0,v0); mug=np.zeros(L); beg=np.zeros(L)
    if ts < L*h:
        k=int(ts//h); a=(ts-k*h)/h
        vimp=v0-g*ts; vout=-e*vimp
        after=lambda t: flight(t-ts,0.0,vout)
        qg=np.where(tn<=ts, qg, after(tn)); qtg=np.where(tc+h/2<=ts, qtg, after(tc+h/2))
        a=min(max(a,0.02),0.98); beg[k]=a-0.5; qtg[k]=0.0; mug[k]=m*(vout-vimp)
    x0=np.r_[qg,qtg,mug,beg]
    lbx=np.r_[q0, np.zeros(L), np.zeros(L), np.zeros(L), -0.49*np.ones(L)]
    ubx=np.r_[q0, np.inf*np.ones(L), np.inf*np.ones(L), np.inf*np.ones(L), 0.49*np.ones(L)]
    lx=0; lg=0
    for s in [1e-1,1e-2,1e-3,1e-5,1e-7,0]:
        sol=S(x0=x0,lbx=lbx,ubx=ubx,lbg=lb,ubg=ub,p=[s,p0],lam_x0=lx,lam_g0=lg); st=S.stats(); tot+=st['iter_count']
        x0=sol['x']; lx=sol['lam_x']; lg=sol['lam_g']
        if st['return_status']!='Solve_Succeeded': print('window',w,'sigma',s,st['return_status']); break
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
