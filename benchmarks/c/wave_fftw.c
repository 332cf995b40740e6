/* Hand-written C reference for the 1-D wave equation u_tt = u_xx - rho u - V'(u), V = u^4/4, on
   n grid points (n even), spectrally discretized, stepped by method B (psi = sinc, phi = 1, the
   two-step form) in the normalized Fourier coefficients Q_j = FFT(u)_j / n, j = 0 .. n/2:

     Q_{n+1} = 2 cos(h w_j) Q_n - Q_{n-1} + h^2 sinc(h w_j) G_j,   G = -FFT(V'(u)) / n,

   with FFTW's real transforms (planned with FFTW_MEASURE). Streamed at every step, as trigint
   streams them: p_n = (Q_{n+1} - Q_{n-1}) / (2 h sinc(h w_j)), U = mean V(u), every mode's
   energy E_j = c_j (|P_j|^2 + w_j^2 |Q_j|^2) / 2 (c_j = 2 for a conjugate pair, 1 for j = 0
   and n/2) with its running max and min, and H = sum_j E_j + U with its max and min.

   Usage: wave_fftw N NSTEPS. Prints microseconds per step. */
#include <complex.h>
#include <fftw3.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
static double now(void){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec+1e-9*t.tv_nsec;}
int main(int argc,char**argv){
 if(argc<3){fprintf(stderr,"usage: wave_fftw N NSTEPS\n");return 2;}
 int n=atoi(argv[1]); long steps=atol(argv[2]); int m=n/2+1;
 double rho=1.0,h=0.01;
 double *u=fftw_alloc_real(n); fftw_complex *X=fftw_alloc_complex(m);
 fftw_plan c2r=fftw_plan_dft_c2r_1d(n,X,u,FFTW_MEASURE), r2c=fftw_plan_dft_r2c_1d(n,u,X,FFTW_MEASURE);
 double complex *Q=malloc(m*sizeof *Q),*Qm=malloc(m*sizeof *Qm),*Qn=malloc(m*sizeof *Qn);
 double *c2=malloc(m*sizeof(double)),*hps=malloc(m*sizeof(double)),*inv=malloc(m*sizeof(double)),
        *w2=malloc(m*sizeof(double)),*wt=malloc(m*sizeof(double)),*hi=malloc(m*sizeof(double)),*lo=malloc(m*sizeof(double));
 for(int j=0;j<m;j++){double w=sqrt(rho+(double)j*j),x=h*w,s=sin(x)/x;
  c2[j]=2*cos(x); hps[j]=h*h*s; inv[j]=1/(2*h*s); w2[j]=w*w; wt[j]=(j==0||j==n/2)?1:2; hi[j]=-1e300; lo[j]=1e300;}
 /* u0 = 0.1 cos x + 0.05 sin 3x, v0 = 0: Q_0 from it, Q_{-1} = Q_0 (a start for timing only) */
 for(int k=0;k<n;k++){double x=2*M_PI*k/n; u[k]=0.1*cos(x)+0.05*sin(3*x);}
 fftw_execute(r2c); for(int j=0;j<m;j++){Q[j]=X[j]/n; Qm[j]=Q[j];}
 double Hhi=-1e300,Hlo=1e300; double t=now();
 for(long s=0;s<steps;s++){
  memcpy(X,Q,m*sizeof *Q); fftw_execute(c2r);           /* u = grid values of Q */
  double U=0; for(int k=0;k<n;k++){double v=u[k],v2=v*v; U+=0.25*v2*v2; u[k]=v2*v;}
  U/=n; fftw_execute(r2c);                               /* X = FFT(V'(u)) */
  double H=U, sc=-1.0/n;
  for(int j=0;j<m;j++){
   double complex g=X[j]*sc, qn=c2[j]*Q[j]-Qm[j]+hps[j]*g, p=(qn-Qm[j])*inv[j];
   double E=0.5*wt[j]*(creal(p)*creal(p)+cimag(p)*cimag(p)+w2[j]*(creal(Q[j])*creal(Q[j])+cimag(Q[j])*cimag(Q[j])));
   hi[j]=hi[j]>E?hi[j]:E; lo[j]=lo[j]<E?lo[j]:E; H+=E; Qn[j]=qn;}
  Hhi=Hhi>H?Hhi:H; Hlo=Hlo<H?Hlo:H;
  double complex *tmp=Qm; Qm=Q; Q=Qn; Qn=tmp;
 }
 double dt=now()-t; printf("%.4f\n",dt/steps*1e6);
 fprintf(stderr,"check %g %g %g\n",creal(Q[1]),Hhi-Hlo,hi[1]-lo[1]); return 0;
}
